"""The fingerprint of the k/m paths: every state and report of the paper's methods.

The logic method (Cartesian, k/m) and Mu et al.'s polar method, on scans measured in
polar form (the simulator's) and in Cartesian form, at clutter 20, 250 and 1000, two seeds,
six scans, plus a variant for each other choice the k/m paths make (ring or expanded
capture, nearest association, the alpha-beta filter, 2/T and 2/3 capture). Each case
feeds its scans one at a time and hashes every report and the state after each scan.

The hashes were taken on the code before issue 28's split of the scan step and before
issue 27's compiled capture and state update; both must leave them unchanged. Integers,
flags and plot ids are hashed exactly; floats to 9 significant digits, so a compiled
kernel that rounds a sum in another order (or another machine's BLAS) does not count
as a change of behaviour, while any decision that changes does.

The score path has its own fingerprint (:data:`SCORE_FINGERPRINTS`): issue 28's work
on the score logic changes it on purpose, and updates it with a note of why.
"""

import hashlib
import json

import numpy as np
import pytest

from plotgate.core.initiation import InitiationConfig, cartesian_scan, initiate
from plotgate.core.initiation.simulate import mu_scenario, simulate

LOGIC = InitiationConfig(
    mode="cartesian", capture_gate="combined", v_max=30.0, confirm_k=3, confirm_m=4
)
POLAR = InitiationConfig(mode="polar", v_max=30.0, confirm_k=3, confirm_m=4, a_max=10.0)
VARIANTS = {
    "logic": LOGIC,
    "polar": POLAR,
    "ring-nearest-alpha_beta": InitiationConfig(
        v_max=30.0, capture_gate="ring", association="nearest", filter="alpha_beta"
    ),
    "expanded-2/T": InitiationConfig(v_max=30.0, capture_gate="expanded", capture_time=2.5),
    "polar-2/3-nearest": InitiationConfig(
        mode="polar", v_max=30.0, capture_scans=3, association="nearest"
    ),
}
CLUTTER = (20.0, 250.0, 1000.0)
"""Clutter plots per scan: nearly empty, the paper's dense case, and one where confirmed
tracks prune tentative ones and compete for plots."""
PRECISION = "%.9g"
DENSITY = 250.0 / 15000.0**2
SCORE = {
    "score-logic": InitiationConfig(
        mode="cartesian",
        capture_gate="combined",
        v_max=30.0,
        confirmation="score",
        P_D=0.8,
        clutter_density=DENSITY,
    ),
    "score-polar": InitiationConfig(
        mode="polar",
        v_max=30.0,
        capture_scans=3,
        confirmation="score",
        P_D=0.8,
        surveillance_area=15000.0**2,
    ),
}


def polar_scans(clutter, seed):
    """Six scans of Mu et al.'s scenario (plots measured in range and azimuth)."""
    return simulate(mu_scenario(clutter, scans=6), seed).scans


def cartesian_scans(clutter, seed):
    """The same scans' positions as Cartesian plots with a fixed 20 m sigma."""
    R = np.eye(2) * 400.0
    return [
        cartesian_scan(s.t, s.z, np.broadcast_to(R, (s.size, 2, 2)))
        for s in polar_scans(clutter, seed)
    ]


def _text(a):
    a = np.asarray(a)
    if a.dtype.kind == "f":
        return np.char.mod(PRECISION, a + 0.0).tolist()  # + 0.0: -0 is 0
    if a.dtype.kind == "O":
        return [_text(v) if isinstance(v, list) else v for v in a.tolist()]
    return a.tolist()


def fingerprint(config, scans):
    """sha256 of every report and of the state after each scan, fed one at a time."""
    digest = hashlib.sha256()
    state = None
    for scan in scans:
        state, (report,) = initiate(state, [scan], config)
        parts = [getattr(report, f) for f in report.__dataclass_fields__]
        parts += [getattr(state.tracks, f) for f in state.tracks.__dataclass_fields__]
        parts += [getattr(state.initiators, f) for f in state.initiators.__dataclass_fields__]
        parts += [state.scans, state.next_track, state.t]
        digest.update(json.dumps([_text(p) for p in parts]).encode())
    return digest.hexdigest()[:16]


CASES = [
    (name, form, clutter, seed)
    for name in VARIANTS
    for form in ("polar", "cartesian")
    for clutter in CLUTTER
    for seed in (1, 2)
]
FINGERPRINTS = {
    "logic-polar-c20-s1": "886e4f2468017468",
    "logic-polar-c20-s2": "53b06f16a12a4e7c",
    "logic-polar-c250-s1": "07ca2e87bb091534",
    "logic-polar-c250-s2": "cec8f77a4f0960fa",
    "logic-polar-c1000-s1": "695aed7f132cdb51",
    "logic-polar-c1000-s2": "bab75d271ae62e66",
    "logic-cartesian-c20-s1": "847b07af25ad142f",
    "logic-cartesian-c20-s2": "26bd48ab8a379551",
    "logic-cartesian-c250-s1": "455dbb9a40acdfca",
    "logic-cartesian-c250-s2": "a20d7d2414f0e355",
    "logic-cartesian-c1000-s1": "066a61107f508392",
    "logic-cartesian-c1000-s2": "8e2f2f788fcf57b4",
    "polar-polar-c20-s1": "4e910ea803ae7070",
    "polar-polar-c20-s2": "92cf346603b5324d",
    "polar-polar-c250-s1": "92e4186c114a979a",
    "polar-polar-c250-s2": "8d6eda2ad7d4cabc",
    "polar-polar-c1000-s1": "94d6ed4ef607ef60",
    "polar-polar-c1000-s2": "afd248e8472c3713",
    "polar-cartesian-c20-s1": "908bf6015ab922c2",
    "polar-cartesian-c20-s2": "ba2aa154e8c666f4",
    "polar-cartesian-c250-s1": "afd9b8ad254d523f",
    "polar-cartesian-c250-s2": "e58865edd7f451ac",
    "polar-cartesian-c1000-s1": "0316475f82485f84",
    "polar-cartesian-c1000-s2": "a98c621191db29ba",
    "ring-nearest-alpha_beta-polar-c20-s1": "ccba3552b9e199c1",
    "ring-nearest-alpha_beta-polar-c20-s2": "8a3be7b5d607dc74",
    "ring-nearest-alpha_beta-polar-c250-s1": "5928c46df114a877",
    "ring-nearest-alpha_beta-polar-c250-s2": "e6d8620d334b582a",
    "ring-nearest-alpha_beta-polar-c1000-s1": "6674ef53cbed8d2c",
    "ring-nearest-alpha_beta-polar-c1000-s2": "dee1572b4b249661",
    "ring-nearest-alpha_beta-cartesian-c20-s1": "fcb8075bf5a024b4",
    "ring-nearest-alpha_beta-cartesian-c20-s2": "52b48aa0697471f9",
    "ring-nearest-alpha_beta-cartesian-c250-s1": "3db5c6400e7d52ca",
    "ring-nearest-alpha_beta-cartesian-c250-s2": "f67c4e1172f45148",
    "ring-nearest-alpha_beta-cartesian-c1000-s1": "f8bc01215a86ef70",
    "ring-nearest-alpha_beta-cartesian-c1000-s2": "54654e32d3216aaa",
    "expanded-2/T-polar-c20-s1": "82396166e1a7faed",
    "expanded-2/T-polar-c20-s2": "ad4ce96352e6d42a",
    "expanded-2/T-polar-c250-s1": "1b45ea2bfdb36abe",
    "expanded-2/T-polar-c250-s2": "40082b2b51093d5d",
    "expanded-2/T-polar-c1000-s1": "2a7e33adf08746bf",
    "expanded-2/T-polar-c1000-s2": "94d37af16ad8e70a",
    "expanded-2/T-cartesian-c20-s1": "bf437f89046f8f86",
    "expanded-2/T-cartesian-c20-s2": "d57eece1ceadfc88",
    "expanded-2/T-cartesian-c250-s1": "5da81ada7e6f506f",
    "expanded-2/T-cartesian-c250-s2": "04a362cf63f44f26",
    "expanded-2/T-cartesian-c1000-s1": "143ed669e34b0065",
    "expanded-2/T-cartesian-c1000-s2": "2eb37671ffefdbba",
    "polar-2/3-nearest-polar-c20-s1": "4f0a32c2f5703f53",
    "polar-2/3-nearest-polar-c20-s2": "666bf9cbe6f0b957",
    "polar-2/3-nearest-polar-c250-s1": "4a33f7caf0c140f0",
    "polar-2/3-nearest-polar-c250-s2": "7610dcda83a10398",
    "polar-2/3-nearest-polar-c1000-s1": "c874c557d5fecb84",
    "polar-2/3-nearest-polar-c1000-s2": "d05ca504d8ab619b",
    "polar-2/3-nearest-cartesian-c20-s1": "b23a17d2d0ab2e52",
    "polar-2/3-nearest-cartesian-c20-s2": "ce5bf7d91f9a7a6f",
    "polar-2/3-nearest-cartesian-c250-s1": "f69237cf0143f3b4",
    "polar-2/3-nearest-cartesian-c250-s2": "cdfa3060e59bca27",
    "polar-2/3-nearest-cartesian-c1000-s1": "e75ab76b2381c379",
    "polar-2/3-nearest-cartesian-c1000-s2": "4630eed674b4d68a",
}
SCORE_FINGERPRINTS = {
    "score-logic-polar-c20-s1": "4696c427fdadd690",
    "score-logic-polar-c20-s2": "995bc196a6a93dfa",
    "score-logic-polar-c250-s1": "a22c17f2ca2c778c",
    "score-logic-polar-c250-s2": "aa7c5ef20217de9d",
    "score-logic-polar-c1000-s1": "3aafff00d0661756",
    "score-logic-polar-c1000-s2": "ae18b1f36dee46ec",
    "score-polar-polar-c20-s1": "3878d4954c62b608",
    "score-polar-polar-c20-s2": "067c68639f7342ce",
    "score-polar-polar-c250-s1": "ae32e150c988b951",
    "score-polar-polar-c250-s2": "85183235fe458f23",
    "score-polar-polar-c1000-s1": "537b68f5be897e07",
    "score-polar-polar-c1000-s2": "f0c94f5ab89a6c7d",
}
"""Taken after issue 28's removal of the score path's structural loss: Cartesian score
gates let in every plot inside Blackman's maximum-likelihood gate, and under score
confirmation every plot no confirmed track holds becomes an initiator, which lives out
its window captured or not (both modes: the polar score's fingerprints move with the
initiators)."""


def _case_id(case):
    name, form, clutter, seed = case
    return f"{name}-{form}-c{clutter:g}-s{seed}"


def _scans(form, clutter, seed):
    return (polar_scans if form == "polar" else cartesian_scans)(clutter, seed)


@pytest.mark.parametrize("case", CASES, ids=_case_id)
def test_the_k_of_m_paths_answer_as_before(case):
    name, form, clutter, seed = case
    assert fingerprint(VARIANTS[name], _scans(form, clutter, seed)) == FINGERPRINTS[_case_id(case)]


SCORE_CASES = [
    (name, "polar", clutter, seed) for name in SCORE for clutter in CLUTTER for seed in (1, 2)
]


@pytest.mark.parametrize("case", SCORE_CASES, ids=_case_id)
def test_the_score_path_answers_as_before(case):
    name, form, clutter, seed = case
    assert (
        fingerprint(SCORE[name], _scans(form, clutter, seed)) == SCORE_FINGERPRINTS[_case_id(case)]
    )


EXISTENCE = {
    "existence": InitiationConfig(
        mode="cartesian",
        capture_gate="combined",
        v_max=30.0,
        confirmation="existence",
        P_D=0.8,
        surveillance_area=15000.0**2,
        existence_confirm=0.9,
    ),
}
EXISTENCE_CASES = [
    ("existence", form, clutter, seed)
    for form in ("polar", "cartesian")
    for clutter in CLUTTER
    for seed in (1, 2)
]
EXISTENCE_FINGERPRINTS = {
    "existence-polar-c20-s1": "5ee90684386f9749",
    "existence-polar-c20-s2": "261e0e5d50ff350d",
    "existence-polar-c250-s1": "caeb7c2fad7dc7b1",
    "existence-polar-c250-s2": "eaccb15a431cbef2",
    "existence-polar-c1000-s1": "e09867f84a8a0660",
    "existence-polar-c1000-s2": "476738e49b339884",
    "existence-cartesian-c20-s1": "88029c0cfe4fba0f",
    "existence-cartesian-c20-s2": "e0a6f8d193e40557",
    "existence-cartesian-c250-s1": "5378d3629aafd862",
    "existence-cartesian-c250-s2": "b3df9f49b3466fb5",
    "existence-cartesian-c1000-s1": "aa18329a9b467f86",
    "existence-cartesian-c1000-s2": "754ad7293558f788",
}
"""Taken when existence confirmation (issue 38, IPDA) was added."""


@pytest.mark.parametrize("case", EXISTENCE_CASES, ids=_case_id)
def test_the_existence_path_answers_as_before(case):
    name, form, clutter, seed = case
    assert (
        fingerprint(EXISTENCE[name], _scans(form, clutter, seed))
        == EXISTENCE_FINGERPRINTS[_case_id(case)]
    )

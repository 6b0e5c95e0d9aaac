"""The identification operations: Kvasnov's Z-test of passive against active tracks

Each declaration is the whole of one operation (:class:`~plotgate.service.schemas.Endpoint`):
its name, path and models, its handler and field map (named, imported on first use), its
work sizes and default caps, its description and example, its scene drawer and the
client's method. :mod:`plotgate.service.table` gathers every capability's declarations.
"""

from plotgate.service.schemas.endpoints import Endpoint, Reference
from plotgate.service.schemas.identification import (
    MAX_SIMULATED_SAMPLES,
    IdentifyPairRequest,
    IdentifyPairResult,
    IdentifyPictureRequest,
    IdentifyPictureResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
)

__all__ = ["OPERATIONS"]

_IDENTIFICATION = "plotgate.service.operations.identification"
_SCENES = "plotgate.service.scenes.identification"

PAIR = Endpoint(
    "identification.pair",
    "/v1/identification/pair",
    "Is a passive (ESM) track the same object as an active radar track? Fisher's "
    "Z-test on bearings",
    IdentifyPairRequest,
    IdentifyPairResult,
    slow=True,
    work={
        "passive_bearings_deg": lambda r: len(r.passive_bearings_deg),
        "active_bearings_deg": lambda r: len(r.active_bearings_deg),
    },
    handler=Reference(_IDENTIFICATION, "pair"),
    fields=Reference(_IDENTIFICATION, "PAIR_FIELDS"),
    drawer=Reference(_SCENES, "pair"),
    client_method="identify_pair",
    description=(
        "Is a passive (ESM) bearing track the same object as an active radar bearing "
        "track? Kvasnov's Fisher Z-test: Z = (mean_active - mean_passive) / (sigma / "
        "sqrt(m)) with circular means and the difference wrapped, sigma known or estimated "
        "from the passive samples; the two-sided p-value and critical value at level "
        "`alpha`, the decision, the type II error beta for a stated minimum separation, "
        "the paper's conditions (n >> m, a normal passive sample) as flags, and the "
        "decision after each active sample. Bearings in degrees."
    ),
    example_body={
        "passive_bearings_deg": [359.8, 0.1, 359.9, 0.2, 0.0, 359.7],
        "active_bearings_deg": [0.1, 359.95],
        "delta_deg": 0.5,
        "beta_max": 0.05,
    },
)

PICTURE = Endpoint(
    "identification.picture",
    "/v1/identification/picture",
    "Z matrix and one-to-one identification of many passive and active tracks",
    IdentifyPictureRequest,
    IdentifyPictureResult,
    slow=True,
    work={
        "passive_deg": lambda r: len(r.passive_deg),
        "active_deg": lambda r: len(r.active_deg),
        "passive_deg x active_deg": lambda r: len(r.passive_deg) * len(r.active_deg),
    },
    # Z, p-values and passes: about 195 bytes a cell in the answer (4,000,000 cells
    # took 1023 MiB of RSS); 2,500,000 take about 720 MiB
    caps={"passive_deg x active_deg": 2_500_000},
    handler=Reference(_IDENTIFICATION, "picture"),
    fields=Reference(_IDENTIFICATION, "PICTURE_FIELDS"),
    drawer=Reference(_SCENES, "picture"),
    client_method="identify_picture",
    description=(
        "Many passive and active bearing tracks at once (Kvasnov's Z-test): the Z matrix "
        "and p-values of every passive x active pair, and a one-to-one identification by "
        "assignment on the pairs that pass the test. Bearings in degrees."
    ),
    example_body={
        "passive_deg": [[10.1, 9.9, 10.0, 10.2], [45.0, 45.3, 44.8, 45.1]],
        "active_deg": [[45.1, 45.0], [10.05, 9.95]],
        "sigma_deg": 0.2,
    },
)

SIMULATE = Endpoint(
    "identification.simulate",
    "/v1/identification/simulate",
    "Kvasnov's experiment by Monte Carlo: realized type I or type II error",
    IdentifySimulateRequest,
    IdentifySimulateResult,
    slow=True,
    work={"runs": lambda r: r.runs, "runs x (n + m)": lambda r: r.runs * (r.n + r.m)},
    # drawn in chunks of 10^6 bearings, so time, not memory, bounds it: 25,000,000
    # bearings take under 1 s of CPU on one core; a cluster gathers one count a
    # chunk, so it may take up to the schema's bound (500 chunks)
    caps={"runs x (n + m)": 25_000_000},
    cluster_caps={"runs x (n + m)": MAX_SIMULATED_SAMPLES},
    handler=Reference(_IDENTIFICATION, "simulate"),
    fields=Reference(_IDENTIFICATION, "SIMULATE_FIELDS"),
    drawer=Reference(_SCENES, "simulate"),
    client_method="simulate_identification",
    description=(
        "Kvasnov's experiment by Monte Carlo: `runs` seeded tests with n passive bearings "
        "N(theta_0, sigma) and m active bearings uniform over a sector of `width_deg` (or "
        "normal), the active object `separation_deg` away: the fraction rejected (the "
        "realized type I error when the separation is 0) and identified (the type II "
        "error beta otherwise), with their binomial standard error. Angles in degrees."
    ),
    example_body={"n": 50, "m": 5, "sigma_deg": 1.0, "runs": 500, "seed": 1},
)

OPERATIONS = (
    PAIR,
    PICTURE,
    SIMULATE,
)

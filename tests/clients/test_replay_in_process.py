"""The in-process runner pays once what it can: the body it sends is the recorded one (held
to the ``json`` module's encoding it replaced), its answers are the registry's for that body
(held to ``execute``), and its alarm is installed once for a run and removed after."""

import json
import math
import signal
import time
from concurrent.futures import ThreadPoolExecutor

from hypothesis import given, settings
from hypothesis import strategies as st

from plotgate.clients.recordings import Exchange
from plotgate.clients.replay import InProcess, in_process, sent_body
from plotgate.service.registry import OPERATIONS, execute

OP = "gates.test"


def _plot(x: float, y: float) -> dict:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[1e4, 0.0], [0.0, 1e4]]}


GOOD = {
    "gate": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
    "first": _plot(0.0, 50_000.0),
    "candidates": [_plot(0.0, 51_000.0), _plot(0.0, 52_600.0)],
}
BODIES = [
    GOOD,
    {**GOOD, "candidates": [{**_plot(0.0, 5e4), "covariance": [[1.0, 2.0], [2.0, 1.0]]}]},
    {**GOOD, "gate": {"kind": "combined", "tau": True}},
    {**GOOD, "first": {**_plot(0.0, 5e4), "x": math.nan}},
    {**GOOD, "first": {**_plot(0.0, 5e4), "x": 10**400}},
    {**GOOD, "note": "\ud800"},
    [1, 2],
    "text",
]


def _exchange(request: dict) -> Exchange:
    return Exchange(OP, "r1", request, {"status": 200, "result": {}})


JSON = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(10**30), 10**30),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=5),
    ),
    lambda kids: (
        st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=3), kids, max_size=4)
    ),
    max_leaves=20,
)


@settings(max_examples=400, deadline=None, derandomize=True)
@given(body=JSON)
def test_the_body_sent_holds_the_values_recorded(body):
    """Read back, the body sent is the one ``json.dumps`` made: the same values and types,
    NaN and Infinity included (compared through one encoding, where NaN equals NaN)."""
    ex = _exchange({"request_id": "r1", "operation": OP, "body": body})
    assert json.dumps(json.loads(sent_body(ex))) == json.dumps(json.loads(ex.body))


def test_a_raw_body_is_sent_as_recorded():
    ex = _exchange({"request_id": "r1", "operation": OP, "raw": '{"gate": '})
    assert sent_body(ex) == b'{"gate": '


def test_answers_are_the_registrys_for_the_recorded_body():
    op = OPERATIONS[OP]
    with InProcess(timeout=60) as run:
        for body in BODIES:
            ex = _exchange({"request_id": "r1", "operation": OP, "body": body})
            answer = run(ex, "new-id")
            expected = execute(op, ex.body, "new-id")
            assert (answer.status, answer.content) == (expected.status, expected.json()), body


def test_the_alarm_is_installed_once_per_run_and_removed_after():
    before = signal.getsignal(signal.SIGALRM)
    ex = _exchange({"request_id": "r1", "operation": OP, "body": GOOD})
    with in_process(timeout=60) as run:
        during = signal.getsignal(signal.SIGALRM)
        assert during is not before
        assert run(ex, "a").status == 200
        assert signal.getsignal(signal.SIGALRM) is during
        assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)  # disarmed between
    assert signal.getsignal(signal.SIGALRM) is before
    assert in_process(timeout=60)(ex, "b").status == 200  # outside with: per exchange
    assert signal.getsignal(signal.SIGALRM) is before


def test_an_exchange_over_its_deadline_is_stopped_in_and_out_of_with(swap_handler):
    def slow(request):
        time.sleep(30)

    swap_handler(OP, slow)
    ex = _exchange({"request_id": "r1", "operation": OP, "body": GOOD})
    started = time.monotonic()
    with InProcess(timeout=0.1) as run:
        answers = [run(ex, "a"), run(ex, "b")]
    answers.append(InProcess(timeout=0.1)(ex, "c"))
    assert time.monotonic() - started < 20
    assert [a.status for a in answers] == [None, None, None]
    assert all("no answer within 0.1 s" in (a.note or "") for a in answers)


def test_outside_the_main_thread_there_is_no_deadline_and_no_alarm():
    """Signals reach only the main thread: a worker thread's runner (fleet replay's) runs
    without a deadline and touches no signal handler."""
    before = signal.getsignal(signal.SIGALRM)
    ex = _exchange({"request_id": "r1", "operation": OP, "body": GOOD})
    with ThreadPoolExecutor(1) as pool:
        answer = pool.submit(InProcess(timeout=60), ex, "a").result(timeout=60)
    assert answer.status == 200
    assert signal.getsignal(signal.SIGALRM) is before


def test_a_deadline_longer_than_the_timer_holds_is_no_deadline():
    """setitimer refuses 1e12 s (time_t): the runner must not answer it as a 500."""
    ex = _exchange({"request_id": "r1", "operation": OP, "body": GOOD})
    with InProcess(timeout=1e12) as run:
        answer = run(ex, "a")
    assert (answer.status, answer.note) == (200, None)


def test_a_body_deeper_than_pydantic_core_serializes_falls_back_to_json():
    """pydantic-core stops at depth 255; the reader takes records up to 256 deep."""
    body: object = 1
    for i in range(254):
        body = [body] if i % 2 else {"a": body}
    ex = _exchange({"request_id": "r1", "operation": OP, "body": body})
    assert json.loads(sent_body(ex)) == body


def test_loading_an_operation_is_not_counted_in_its_first_replayed_duration(tmp_path, monkeypatch):
    """The first exchange of an operation waits for its module (and, on a first start, its
    kernels' compilation): that wait happens before the exchange's clock starts. A fake
    clock moves only while the operation loads."""
    from fastapi.testclient import TestClient

    from plotgate.clients import replay as replay_module
    from plotgate.clients.recordings import read_recording
    from plotgate.service.app import create_app
    from plotgate.service.config import Settings

    folder = tmp_path / "recorded"
    with TestClient(create_app(Settings(log_dir=folder, git_commit="test"))) as client:
        for i in range(2):
            assert client.post("/v1/gates/test", json=GOOD).status_code == 200, i
    clock = [0.0]

    class Clock:
        @staticmethod
        def perf_counter() -> float:
            return clock[0]

    def load(operation: str) -> None:
        clock[0] += 100.0

    monkeypatch.setattr(replay_module, "time", Clock)
    out = tmp_path / "replayed.mcap"
    report = replay_module.replay(folder, out=out, progress=False, load=load)
    assert (report.compared, report.unchanged, clock[0]) == (2, 2, 100.0)
    durations = [ex.response["duration_s"] for ex in read_recording(out).exchanges]
    assert durations == [0.0, 0.0]

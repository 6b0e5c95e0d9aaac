"""A fault is not an answer: replay sets 503s aside, recorded or replayed.

A large-body worker killed mid-request was recorded as 500 and replay reported CHANGED
(exit 1). It is recorded as 503 ``worker-lost`` now, and a recorded 503 of any cause is
not compared; nor is a 503 the replaying server answers now. Each is counted apart with
its reason, so the tally still adds up, and a replay with nothing compared exits 2.
"""

from plotgate.clients.recordings import Exchange
from plotgate.clients.replay import FAULT_NOW, REFUSED_FOR_THE_SERVER, Answer, judge, replay
from plotgate.service.problems import ProblemError, problem_json
from plotgate.service.recording import request_record, response_record
from plotgate.service.registry import OPERATIONS
from tests.support.recorded import OP, write_files

T0, MS = 1_700_000_000_000_000_000, 1_000_000


def test_a_recorded_worker_lost_is_set_aside(tmp_path):
    problem = problem_json(
        ProblemError("worker-lost", 503, "the worker died"), OPERATIONS[OP].path, "r0"
    )
    events = [
        (T0, "request", request_record("r0", OP, b"{}")),
        (T0 + MS, "response", response_record("r0", OP, 503, 0.5, problem)),
    ]
    write_files(tmp_path / "rec", events, set())
    report = replay(tmp_path / "rec", progress=False)
    assert (report.compared, report.changed) == (0, 0)
    assert report.not_compared == {REFUSED_FOR_THE_SERVER: 1}
    assert report.exit_code() == 2  # nothing comparable


def test_a_503_of_the_replaying_server_is_set_aside():
    exchange = Exchange(
        OP,
        "r0",
        {"request_id": "r0", "operation": OP, "body": {}},
        {"request_id": "r0", "operation": OP, "status": 200, "duration_s": 0.1, "result": {}},
        T0,
    )
    fault = {"type": "urn:plotgate:problem:worker-lost", "title": "Worker lost", "status": 503}

    def faulty(exchange: Exchange, rid: str) -> Answer:
        return Answer(503, fault)

    assert judge(exchange, faulty, 1e-9, 1e-12).skip == FAULT_NOW

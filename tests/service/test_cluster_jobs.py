"""Every heavy job on Dask: the same answer bit for bit in-process and on 1 and 2 workers.

Each job is answered through the registry, as the service and ``plotgate call`` answer it,
in this process and then with the chunks on a LocalCluster (loopback only); the answers'
bytes must be equal. ``tests/service/test_cluster.py`` holds the cluster's own behaviour
(addresses, timeouts, the scheduler lost) on ``initiation.evaluate``.
"""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from distributed import Client, LocalCluster

from plotgate.clients.cli import main
from plotgate.core.multistatic.study import STUDY_CHUNK_RUNS, accuracy_study
from plotgate.service.cluster import cluster, mapper, numba_threads
from plotgate.service.registry import OPERATIONS, execute
from tests.support.identical import assert_identical
from tests.support.servers import losing_a_worker

EXAMPLE = json.loads(
    (Path(__file__).resolve().parents[2] / "docs/examples/study_scenario.json").read_text()
)
STUDY = {**EXAMPLE, "sample_times": EXAMPLE["sample_times"][:12], "runs": 250, "tracks": True}
"""Three chunks of solves, the last one short."""
JOBS = {
    "initiation.evaluate": {
        "runs": 60,
        "seed": 3,
        "scenario": {"clutter": 50},
        "config": {"mode": "polar", "v_max": 30},
        "sweep": {"parameter": "confirm", "values": ["2/4", "3/4"]},
    },
    "solves.study": STUDY,
    "identification.simulate": {"runs": 50_000, "seed": 5},  # three chunks of 50 + 5
    "gates.probability_curve": {
        "gate": {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
        "mark": {"r": 20_000.0, "az_deg": 0.0, "sigma_r": 200.0, "sigma_az_deg": 0.5},
        "tau": 5.0,
        "against": "range",
        "values": [20_000.0, 50_000.0, 80_000.0],
        "prior": {"kind": "area", "v_min": 100.0, "v_max": 500.0},
    },
}


def answer(name: str) -> bytes:
    outcome = execute(OPERATIONS[name], json.dumps(JOBS[name]).encode())
    assert outcome.status == 200, outcome.content
    return outcome.content


@pytest.fixture(scope="module")
def alone() -> dict[str, bytes]:
    return {name: answer(name) for name in JOBS}


@pytest.fixture(scope="module", params=[1, 2], ids=["1 worker", "2 workers"])
def monitor(request):
    """A LocalCluster of 1 or 2 workers, the open cluster for the test, and a client of
    it that watches the workers."""
    with (
        LocalCluster(
            n_workers=request.param, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        Client(local) as watching,
        cluster(address=local.scheduler_address),
    ):
        yield watching


def executed(monitor: Client) -> int:
    """Tasks the cluster's workers have run so far."""
    return sum(monitor.run(lambda dask_worker: dask_worker.state.executed_count).values())


@pytest.mark.parametrize("name", list(JOBS))
def test_each_job_answers_the_same_bytes_on_a_local_cluster(name, alone, monitor):
    before = executed(monitor)
    assert answer(name) == alone[name]
    assert executed(monitor) - before == 3  # each job's three chunks ran on the workers


def test_the_study_cli_writes_the_same_table_on_two_workers(tmp_path, capsys):
    request = tmp_path / "study.json"
    request.write_text(json.dumps({**STUDY, "runs": 120, "tracks": False}))
    here, there = tmp_path / "here.md", tmp_path / "there.md"
    for table, where in ((here, []), (there, ["--local-workers", "2"])):
        code = main(["study", str(request), "--no-png", "--table", str(table), *where])
        assert code in (0, 1), capsys.readouterr().err
    assert here.read_text() == there.read_text()


@pytest.mark.parametrize("command", ["study", "plot"])
def test_the_study_and_plot_clis_end_with_exit_2_without_a_scheduler(command, tmp_path, capsys):
    figure = ["compare", "--points", "2", "--out", str(tmp_path / "c.png")]
    args = ["--no-png", "--runs", "2"] if command == "study" else figure
    assert main([command, *args, "--dask", "tcp://127.0.0.1:9"]) == 2
    assert "no Dask scheduler answers at tcp://127.0.0.1:9" in capsys.readouterr().err


def test_a_progress_bar_counts_the_study_s_chunks_on_stderr(capsys):
    body = json.dumps({**STUDY, "tracks": False}).encode()
    with cluster(progress=True):
        execute(OPERATIONS["solves.study"], body)
    assert "3/3" in capsys.readouterr().err
    execute(OPERATIONS["solves.study"], body)  # outside: no bar
    assert capsys.readouterr().err == ""


def test_a_worker_killed_mid_study_changes_nothing():
    t = np.asarray(STUDY["sample_times"][:10]) * 4.0
    rx = [[10_000.0, 0.0], [0.0, 10_000.0], [-8000.0, -6000.0]]
    # 200 chunks, about 4 s in one process: still running a second in, on any machine
    args = (t, [0.0, 0.0], rx, [3000.0, 4000.0], [0.0, 80.0], 0.5, 200 * STUDY_CHUNK_RUNS, 9)

    def study(address: str):
        with cluster(address=address):
            return accuracy_study(*args, mapper=mapper())

    assert_identical(losing_a_worker(study, after=1.0), accuracy_study(*args))


def test_bad_input_is_refused_before_an_unreachable_scheduler_is_tried(settings):
    """422 naming the field, not 503: core checks the request before any work is mapped."""
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    receiver = STUDY["receivers"][0]
    on_a_receiver = {**STUDY, "target": {**receiver}}
    unreachable = settings.model_copy(update={"dask_scheduler": "tcp://127.0.0.1:9"})
    with TestClient(create_app(unreachable), raise_server_exceptions=False) as c:
        r = c.post(OPERATIONS["solves.study"].path, json=on_a_receiver)
        assert r.status_code == 422, r.text
        assert r.json()["errors"][0]["field"].startswith("target")
        assert c.post(OPERATIONS["solves.study"].path, json=STUDY).status_code == 503


def test_local_workers_share_the_cores_among_their_numba_threads():
    with cluster(local_workers=2):
        threads = mapper()(os.getenv, ["NUMBA_NUM_THREADS"] * 4)
    assert threads == [str(numba_threads(2))] * 4
    assert numba_threads(2) == max(1, (os.cpu_count() or 1) // 2) and numba_threads(64) == 1

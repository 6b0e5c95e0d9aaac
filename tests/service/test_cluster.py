"""Monte Carlo on Dask: the same numbers bit for bit in-process, on 1 and 2 workers, and
after a worker dies mid-evaluation.

Each test that needs a cluster starts a LocalCluster of single-threaded worker processes
(about a second here) and closes it.
"""

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest
from distributed import Client, LocalCluster

from plotgate.clients.cli import main
from plotgate.core.initiation import InitiationConfig
from plotgate.core.initiation.evaluate import CHUNK_RUNS, evaluate, sweep
from plotgate.core.initiation.simulate import mu_scenario
from plotgate.service.cluster import CONNECT_S, ClusterUnavailable, cluster, configure, mapper
from tests.support.servers import free_port, losing_a_worker, serve

SCORE = InitiationConfig(
    mode="polar", v_max=30.0, confirmation="score", P_D=0.8, surveillance_area=15000.0**2
)


def same(a, b):
    assert a.true.tolist() == b.true.tolist() and a.false.tolist() == b.false.tolist()
    assert (a.mean_true, a.se_true, a.mean_false, a.se_false, a.ceiling) == (
        b.mean_true,
        b.se_true,
        b.mean_false,
        b.se_false,
        b.ceiling,
    )
    assert a.mean_time_to_confirmation == b.mean_time_to_confirmation or (
        np.isnan(a.mean_time_to_confirmation) and np.isnan(b.mean_time_to_confirmation)
    )


def test_a_runs_seed_is_the_child_spawn_gives():
    children = np.random.SeedSequence(2026).spawn(60)
    for r in (0, 1, 24, 25, 59):
        mine = np.random.SeedSequence(2026, spawn_key=(r,))
        assert (mine.generate_state(8) == children[r].generate_state(8)).all()


def test_chunks_run_in_any_order_give_the_same_evaluation():
    runs = 2 * CHUNK_RUNS + 7  # a short last chunk

    def backwards(function, items):
        items = list(items)
        return [function(x) for x in reversed(items)][::-1]

    scenario = mu_scenario(100.0)
    same(evaluate(scenario, SCORE, runs, 5, mapper=backwards), evaluate(scenario, SCORE, runs, 5))


@pytest.mark.parametrize("workers", [1, 2])
def test_on_a_local_cluster_the_numbers_are_the_in_process_ones(workers):
    scenario = mu_scenario(100.0)
    alone = sweep(scenario, SCORE, "false_confirmation", [0.01, 0.3], 60, 3, baseline=True)
    with cluster(local_workers=workers):
        assert mapper() is not None
        spread = sweep(scenario, SCORE, "false_confirmation", [0.01, 0.3], 60, 3, baseline=True)
    assert mapper() is None
    for a, b in zip(alone, spread, strict=True):
        same(a, b)


def test_the_cli_answers_the_same_on_a_cluster(tmp_path, capsys):
    body = tmp_path / "evaluate.json"
    body.write_text(
        json.dumps(
            {
                "runs": 40,
                "scenario": {"clutter": 50},
                "config": {"mode": "polar", "v_max": 30},
                "sweep": {"parameter": "confirm", "values": ["2/4", "3/4"]},
            }
        )
    )
    assert main(["call", "initiation.evaluate", str(body)]) == 0
    alone = capsys.readouterr().out
    assert main(["call", "initiation.evaluate", str(body), "--local-workers", "2"]) == 0
    assert capsys.readouterr().out == alone


def test_an_unreachable_scheduler_is_exit_2_with_a_message(tmp_path, capsys):
    body = tmp_path / "evaluate.json"
    body.write_text('{"runs": 2}')
    assert main(["call", "initiation.evaluate", str(body), "--dask", "tcp://127.0.0.1:9"]) == 2
    assert "no Dask scheduler answers at tcp://127.0.0.1:9" in capsys.readouterr().err
    # not an address at all: exit 2 with a message, no traceback
    assert main(["call", "initiation.evaluate", str(body), "--dask", "not-an-address"]) == 2
    assert "'not-an-address' is no Dask scheduler address" in capsys.readouterr().err
    assert main(["worker", "not-an-address"]) == 2
    assert "plotgate worker: 'not-an-address' is no Dask scheduler address" in (
        capsys.readouterr().err
    )


def test_a_worker_killed_mid_evaluation_changes_nothing():
    scenario = mu_scenario(250.0)
    runs = 96 * CHUNK_RUNS  # about 9 s of CPU: the kill at 1.5 s lands mid-way on two workers

    def evaluation(address: str):
        with cluster(address=address):
            return evaluate(scenario, SCORE, runs, 11, mapper=mapper())

    same(losing_a_worker(evaluation), evaluate(scenario, SCORE, runs, 11))


def test_plotgate_worker_joins_a_scheduler_and_leaves_on_sigterm():
    scenario = mu_scenario(50.0)
    expected = evaluate(scenario, SCORE, 50, 4)
    with (
        LocalCluster(n_workers=0, processes=True, dashboard_address=":0") as local,
        Client(local) as client,
    ):
        worker = subprocess.Popen(
            [sys.executable, "-m", "plotgate.clients.cli", "worker", local.scheduler_address],
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            client.wait_for_workers(1, timeout=60)
            with cluster(address=local.scheduler_address):
                same(evaluate(scenario, SCORE, 50, 4, mapper=mapper()), expected)
        finally:
            worker.send_signal(signal.SIGTERM)
            _, err = worker.communicate(timeout=60)
    assert worker.returncode == 0, err
    assert f"plotgate worker: left {local.scheduler_address}" in err


# ---------------------------------------------------------------- the service on a cluster

BODY = {
    "runs": 60,
    "seed": 2,
    "scenario": {"clutter": 50},
    "config": {"mode": "polar", "v_max": 30},
}


def _post(settings, body=BODY):
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        return c.post("/v1/initiation/evaluate", json=body)


def test_the_service_sends_its_runs_to_plotgate_dask_scheduler(settings):
    alone = _post(settings)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as local:
        spread = _post(settings.model_copy(update={"dask_scheduler": local.scheduler_address}))
    assert spread.status_code == alone.status_code == 200
    assert spread.json() == alone.json()


def test_an_unreachable_scheduler_answers_503_with_retry_after_and_is_recorded(settings):
    from plotgate.clients.recordings import read_recording

    garbled = _post(settings.model_copy(update={"dask_scheduler": "not-an-address"}))
    assert garbled.status_code == 503 and "retry-after" in garbled.headers
    assert "'not-an-address' is no Dask scheduler address" in garbled.json()["detail"]
    r = _post(settings.model_copy(update={"dask_scheduler": "tcp://127.0.0.1:9"}))
    assert r.status_code == 503 and r.headers["retry-after"] == "1"
    assert r.headers["content-type"] == "application/problem+json"
    problem = r.json()
    assert problem["type"].endswith("cluster-unavailable")
    assert "no Dask scheduler answers at tcp://127.0.0.1:9" in problem["detail"]
    [path] = sorted(settings.log_dir.glob("*.mcap"))[-1:]
    [exchange] = read_recording(path).exchanges
    assert exchange.operation == "initiation.evaluate" and exchange.response["status"] == 503


def test_work_past_the_timeout_answers_504_not_retried(settings):
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as local:
        # connecting counts against the timeout too: 1 s leaves the connection to a local
        # scheduler room, and not 300 runs in dense clutter on one worker
        update = {"dask_scheduler": local.scheduler_address, "dask_timeout_s": 1.0}
        heavy = {**BODY, "runs": 300, "scenario": {"clutter": 500}}
        r = _post(settings.model_copy(update=update), heavy)
    assert r.status_code == 504 and "retry-after" not in r.headers
    assert r.json()["type"] == "urn:plotgate:problem:cluster-timeout"
    assert "did not finish on the cluster within 1 s" in r.json()["detail"]


def test_a_scheduler_with_no_workers_answers_a_recorded_503_with_its_cause(settings):
    """An in-cap request on a scheduler no worker has joined waited the whole
    PLOTGATE_DASK_TIMEOUT_S (300 s) for its 504; it is answered 503 cluster-unavailable,
    saying why, within NO_WORKERS_S and a poll (30 s: a hang detector), and recorded as a
    503, which replay sets aside."""
    with LocalCluster(n_workers=0, processes=True, dashboard_address=":0") as local:
        update = {"dask_scheduler": local.scheduler_address, "dask_timeout_s": 300.0}
        started = time.monotonic()
        r = _post(settings.model_copy(update=update))
        took = time.monotonic() - started
    print(f"503 after {took:.1f} s")
    assert r.status_code == 503 and r.headers["retry-after"] == "1", r.text
    assert r.json()["type"] == "urn:plotgate:problem:cluster-unavailable"
    assert "has had no worker" in r.json()["detail"]
    assert took < 30
    assert [e.response["status"] for e in _exchanges(settings)] == [503]


def test_the_compose_file_names_this_builds_commands_and_settings():
    from pathlib import Path

    import yaml

    from plotgate.service.config import Settings

    root = Path(__file__).parents[2]
    services = yaml.safe_load((root / "deploy/compose.yaml").read_text())["services"]
    assert services["worker"]["command"][:2] == ["plotgate", "worker"]
    assert (
        services["worker"]["command"][2]
        == services["plotgate"]["environment"]["PLOTGATE_DASK_SCHEDULER"]
    )
    for name in services["plotgate"]["environment"]:
        assert name.removeprefix("PLOTGATE_").lower() in Settings.model_fields


def test_the_compose_file_publishes_loopback_only_and_records_where_the_server_can_write():
    """What running it for real found (deploy/run_stack.sh, docs/deploy.md): podman-compose
    starts one worker unless the mode is written out, a host folder bind-mounted on /data
    is root's, where the server (user 10001) cannot write, and a worker leaves with exit 0
    when its scheduler dies, which ``on-failure`` does not restart."""
    from pathlib import Path

    import yaml

    compose = yaml.safe_load((Path(__file__).parents[2] / "deploy/compose.yaml").read_text())
    services = compose["services"]
    assert services["worker"]["deploy"] == {"mode": "replicated", "replicas": 2}
    assert services["worker"]["restart"] == "unless-stopped"  # they leave with a scheduler
    published = [port for s in services.values() for port in s.get("ports", [])]
    assert published and all(port.startswith("127.0.0.1:") for port in published)
    [volume] = services["plotgate"]["volumes"]
    name, target = volume.split(":")
    assert target == "/data" and name in compose["volumes"]


def test_a_progress_bar_counts_the_chunks_on_stderr(capsys):
    scenario = mu_scenario(20.0)
    runs = 3 * CHUNK_RUNS
    with cluster(progress=True):
        ev = evaluate(scenario, SCORE, runs, 1, mapper=mapper())
    assert "3/3" in capsys.readouterr().err
    same(ev, evaluate(scenario, SCORE, runs, 1))
    with cluster(local_workers=1, progress=True):
        evaluate(scenario, SCORE, runs, 1, mapper=mapper())
    assert "3/3" in capsys.readouterr().err
    evaluate(scenario, SCORE, runs, 1, mapper=mapper())  # outside: no bar
    assert capsys.readouterr().err == ""


def test_a_malformed_address_never_builds_a_client_however_often_it_is_asked(monkeypatch):
    """Each failed Client start left a Client behind whose finalizer, run by a later
    start's garbage collection, deadlocked the service after about 15 requests."""
    import distributed

    from plotgate.service.cluster import ClusterUnavailable, configure

    built = []
    monkeypatch.setattr(distributed, "Client", lambda *a, **k: built.append(a))
    configure("tcp://host-without-port", 5.0)
    try:
        for _ in range(50):
            with pytest.raises(ClusterUnavailable, match="is no Dask scheduler address"):
                mapper()
    finally:
        configure(None)
    assert built == []


# ------------------------------------------------- a scheduler address that is no scheduler
#
# Dask's connect timeout does not cover a peer that accepts and never speaks (its handshake
# read has no deadline), and a peer that speaks first is parsed as Dask frames (an HTTP
# status line read as a 3 EiB frame length). Each peer below listens on 127.0.0.1 and
# holds every connection it accepts for at most PEER_HOLD_S.

PEER_HOLD_S = 120.0
TIMEOUT_S = 3.0  # PLOTGATE_DASK_TIMEOUT_S in these tests: below cluster.CONNECT_S
MARGIN_S = 10.0  # a hang detector on a loaded machine, not a speed figure


def _listen() -> socket.socket:
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    sock.settimeout(0.2)
    return sock


@contextlib.contextmanager
def _peer(greeting: bytes | None) -> Iterator[str]:
    """A port that accepts and sends ``greeting`` (None: nothing), then holds the
    connection open; yields its Dask address."""
    sock, stop, held = _listen(), threading.Event(), []

    def accept() -> None:
        deadline = time.monotonic() + PEER_HOLD_S
        while not stop.is_set() and time.monotonic() < deadline:
            try:
                conn, _ = sock.accept()
            except TimeoutError:
                continue
            if greeting is not None:
                conn.sendall(greeting)
            held.append(conn)

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(timeout=5)
        for conn in held:
            conn.close()
        sock.close()


@contextlib.contextmanager
def _http_server(folder) -> Iterator[str]:
    """``python3 -m http.server`` on a loopback port: reads a request line, and waits."""
    import functools
    from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

    class Quiet(SimpleHTTPRequestHandler):
        def log_message(self, *args) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(folder)))
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.1})
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)


@pytest.fixture(params=["silent", "banner", "http"])
def no_scheduler(request, tmp_path) -> Iterator[str]:
    """The address of a port that is no Dask scheduler, each kind in turn."""
    if request.param == "http":
        with _http_server(tmp_path) as address:
            yield address
    else:
        banner = (
            b"HTTP/1.1 200 OK\r\nServer: not-dask\r\n\r\n" if request.param == "banner" else None
        )
        with _peer(banner) as address:
            yield address


def _exchanges(settings):
    from plotgate.clients.recordings import read_recording

    return [
        e
        for path in sorted(settings.log_dir.glob("*.mcap"))
        for e in read_recording(path).exchanges
    ]


def test_a_port_that_is_no_scheduler_answers_a_recorded_503_in_time(settings, no_scheduler):
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    update = {"dask_scheduler": no_scheduler, "dask_timeout_s": TIMEOUT_S}
    app = create_app(settings.model_copy(update=update))
    started = time.monotonic()
    with TestClient(app, raise_server_exceptions=False) as c:
        body = {"scenario": {"scans": 4, "clutter": 5}, "runs": 30, "seed": 1}
        r = c.post("/v1/initiation/evaluate", json=body)
        answered = time.monotonic()
    closed = time.monotonic()
    assert r.status_code == 503, r.text
    assert r.headers["retry-after"] == "1"
    assert r.json()["type"] == "urn:plotgate:problem:cluster-unavailable"
    assert f"no Dask scheduler answers at {no_scheduler}" in r.json()["detail"]
    assert answered - started < TIMEOUT_S + MARGIN_S
    assert closed - answered < MARGIN_S  # the shutdown waited on nothing
    [exchange] = _exchanges(settings)
    assert exchange.response["status"] == 503


def test_the_cli_ends_with_a_message_and_exit_2_on_a_port_that_is_no_scheduler(
    tmp_path, capsys, no_scheduler
):
    body = tmp_path / "evaluate.json"
    body.write_text('{"runs": 2}')
    started = time.monotonic()
    assert main(["call", "initiation.evaluate", str(body), "--dask", no_scheduler]) == 2
    assert time.monotonic() - started < CONNECT_S + MARGIN_S
    err = capsys.readouterr().err
    assert f"plotgate call: no Dask scheduler answers at {no_scheduler}" in err
    assert "Traceback" not in err


def test_reconfiguring_releases_a_caller_stuck_on_a_silent_scheduler_at_once():
    """What the service's shutdown does (``configure(None)``): the call in flight ends
    now, not at its deadline."""
    outcome = {}

    def call() -> None:
        try:
            mapper()
        except ClusterUnavailable as exc:
            outcome["error"] = exc

    with _peer(None) as address:
        configure(address, 120.0)
        thread = threading.Thread(target=call, daemon=True)
        thread.start()
        time.sleep(1.0)  # connecting, to a peer that will not speak in 120 s
        released = time.monotonic()
        configure(None)
        thread.join(timeout=MARGIN_S)
        assert not thread.is_alive()
        assert time.monotonic() - released < MARGIN_S
    assert "the call was cancelled" in str(outcome["error"])


def test_a_task_s_own_error_comes_back_as_the_task_raised_it():
    """Only what Dask raises is the cluster's: a chunk's own error is the same error it
    would be in this process (core's error answers 4xx, a bug 500), not a 503."""
    with cluster(local_workers=1):
        with pytest.raises(ZeroDivisionError):
            mapper()(lambda x: 1 / x, [1, 0])


def _scheduler(port: int) -> subprocess.Popen:
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "distributed.cli.dask_scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--no-dashboard",
            "--dashboard-address",
            ":0",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _worker(address: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "plotgate.clients.cli", "worker", address],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def test_a_scheduler_killed_mid_request_answers_a_recorded_503_and_is_used_once_back(settings):
    """The issue's fault: the scheduler process killed while a request's chunks run on it
    answers that request 503 ``cluster-unavailable`` with ``Retry-After``, recorded; a
    scheduler started again on the same port (and a worker joining it) runs the next
    request, on the same server, without a restart of it."""
    from fastapi.testclient import TestClient

    from plotgate.service.app import create_app

    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = [_scheduler(port), _worker(address)]
    try:
        with Client(address, timeout="60s") as monitor:
            monitor.wait_for_workers(1, timeout=120)
            update = {"dask_scheduler": address, "dask_timeout_s": 120.0}
            app = create_app(settings.model_copy(update=update))
            outcome = {}
            with TestClient(app, raise_server_exceptions=False) as c:
                heavy = {**BODY, "runs": 1000, "scenario": {"clutter": 500}}
                thread = threading.Thread(
                    target=lambda: outcome.update(r=c.post("/v1/initiation/evaluate", json=heavy)),
                    daemon=True,
                )
                thread.start()
                deadline = time.monotonic() + 120
                while not any(monitor.processing().values()):  # the work has reached a worker
                    assert time.monotonic() < deadline and thread.is_alive()
                    time.sleep(0.1)
                monitor.close()
                killed = time.monotonic()
                for process in processes:
                    process.kill()
                thread.join(timeout=CONNECT_S + MARGIN_S + 30)
                assert not thread.is_alive()
                answered = time.monotonic()
                processes += [_scheduler(port), _worker(address)]  # back, on the same port
                with Client(address, timeout="60s") as back:
                    back.wait_for_workers(1, timeout=120)
                    again = c.post("/v1/initiation/evaluate", json=BODY)
                    executed = _executed(back)
            closed = time.monotonic()
    finally:
        for process in processes:
            process.kill()
            process.wait(timeout=30)
    r = outcome["r"]
    assert r.status_code == 503, r.text
    assert r.headers["retry-after"] == "1"
    assert r.json()["type"] == "urn:plotgate:problem:cluster-unavailable"
    assert answered - killed < CONNECT_S + MARGIN_S
    assert again.status_code == 200, again.text
    assert again.json()["runs"] == BODY["runs"]
    assert executed == -(-BODY["runs"] // CHUNK_RUNS)  # every chunk, on the new scheduler
    assert closed - answered < 300  # a hang detector only
    assert [e.response["status"] for e in _exchanges(settings)] == [503, 200]


@contextlib.contextmanager
def _scheduler_and_worker() -> Iterator[tuple[str, subprocess.Popen, Client]]:
    """A ``dask scheduler`` on a free loopback port with one ``plotgate worker`` joined:
    its address, the scheduler's process (to kill) and a client watching it; both
    processes are killed after."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler, worker = _scheduler(port), _worker(address)
    try:
        monitor = Client(address, timeout="60s")
        monitor.wait_for_workers(1, timeout=120)
        yield address, scheduler, monitor
    finally:
        for process in (scheduler, worker):
            process.kill()
            process.wait(timeout=30)


def test_a_scheduler_killed_mid_study_ends_the_cli_with_one_message_and_exit_2(tmp_path):
    """No traceback of Dask's client reconnecting: the command's own line says it all."""
    with _scheduler_and_worker() as (address, scheduler, monitor):
        with monitor:
            study = subprocess.Popen(
                [sys.executable, "-m", "plotgate.clients.cli", "study", "--dask", address]
                + ["--runs", "1000", "--no-png", "--table", str(tmp_path / "table.md")],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            deadline = time.monotonic() + 120
            while not any(monitor.processing().values()):  # the work has reached the worker
                assert time.monotonic() < deadline and study.poll() is None
                time.sleep(0.1)
        scheduler.kill()
        try:
            _, err = study.communicate(timeout=120)
        finally:
            study.kill()
    assert study.returncode == 2
    assert "Traceback" not in err and err.startswith("plotgate: 503 Cluster unavailable"), err


def test_sigterm_answers_a_stuck_cluster_call_503_within_the_graceful_timeout(tmp_path):
    """The issue's shutdown, on a real server: a request whose work waits on a scheduler
    with no workers (PLOTGATE_DASK_TIMEOUT_S 600), then SIGTERM. The server stops within
    its graceful-shutdown timeout, and the request is answered 503 and recorded before,
    not cut by uvicorn (an unrecorded bare 500) nor waited on for 600 s."""
    import httpx

    from plotgate.clients.recordings import read_recording

    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _scheduler(port)
    env = {
        "PLOTGATE_DASK_SCHEDULER": address,
        "PLOTGATE_DASK_TIMEOUT_S": "600",
        "PLOTGATE_GRACEFUL_SHUTDOWN_S": "3",
    }
    log, recordings, outcome = tmp_path / "serve.log", tmp_path / "recordings", {}
    try:
        with (
            Client(address, timeout="60s") as monitor,
            serve(recordings, env=env, log=log) as (proc, url),
        ):
            body = {"scenario": {"scans": 4, "clutter": 5}, "runs": 30, "seed": 1}

            def post() -> None:
                outcome["r"] = httpx.post(url + "/v1/initiation/evaluate", json=body, timeout=60)

            thread = threading.Thread(target=post, daemon=True)
            thread.start()
            deadline = time.monotonic() + 60
            while not _scheduler_tasks(monitor):  # the chunks wait there for a worker
                assert time.monotonic() < deadline and thread.is_alive()
                time.sleep(0.1)
            stopping = time.monotonic()
            proc.terminate()
            proc.wait(timeout=60)
            stopped = time.monotonic()
            thread.join(timeout=MARGIN_S)
    finally:
        scheduler.kill()
        scheduler.wait(timeout=30)
    # uvicorn shuts down gracefully, then re-raises the signal: exit by SIGTERM
    assert proc.returncode in (0, -signal.SIGTERM)
    assert stopped - stopping < 3 + MARGIN_S
    r = outcome["r"]
    assert r.status_code == 503 and r.headers["retry-after"] == "1", r.text
    assert r.json()["type"] == "urn:plotgate:problem:cluster-unavailable"
    assert "timeout graceful shutdown exceeded" not in log.read_text()
    [path] = recordings.glob("*.mcap")
    [exchange] = read_recording(path).exchanges
    assert exchange.response["status"] == 503


def _scheduler_tasks(monitor: Client) -> int:
    """How many tasks the scheduler holds."""

    def tasks(dask_scheduler) -> int:
        return len(dask_scheduler.tasks)

    with _by_value():
        return monitor.run_on_scheduler(tasks)


def _executed(monitor: Client) -> int:
    """How many tasks the workers of ``monitor``'s scheduler have run since they started."""

    def executed(dask_worker) -> int:
        return dask_worker.state.executed_count

    with _by_value():
        return sum(monitor.run(executed).values())


@contextlib.contextmanager
def _by_value() -> Iterator[None]:
    """This module's functions sent to the cluster by value: it cannot import them."""
    import cloudpickle

    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)
    try:
        yield
    finally:
        cloudpickle.unregister_pickle_by_value(module)


# ---------------------------------------------------------------- the client going away


def test_cancellable_work_gives_the_same_numbers_and_stops_once_cancelled():
    """Inside ``Cancellable.run`` the in-process map is the one that checks for a cancel
    before each chunk: the same numbers bit for bit; once cancelled, no chunk starts."""
    from plotgate.service.cluster import Cancellable, WorkCancelled

    scenario = mu_scenario(20.0)
    alone = evaluate(scenario, SCORE, 2 * CHUNK_RUNS, seed=5)
    same(
        Cancellable().run(lambda: evaluate(scenario, SCORE, 2 * CHUNK_RUNS, 5, mapper=mapper())),
        alone,
    )
    cancelled = Cancellable()
    cancelled.cancel()
    started = []
    with pytest.raises(WorkCancelled):
        cancelled.run(lambda: mapper()(started.append, [1, 2]))
    assert started == []


LONG_WORK = {**BODY, "runs": 1500, "scenario": {"clutter": 250}}
"""60 chunks, about a minute on this machine in-process or on one worker: work still
running after the client left is seen (answered 200, tasks left on the scheduler)."""

LONG_WORK_LIMITS = '{"initiation.evaluate": {"runs x scans x plots": 100000000}}'
"""An operator's cap that takes LONG_WORK in one process."""


def _given_up(url: str) -> None:
    """Post LONG_WORK and go away 2 s later (the read timeout closes the connection)."""
    import httpx

    with pytest.raises(httpx.ReadTimeout):
        httpx.post(url + "/v1/initiation/evaluate", json=LONG_WORK, timeout=2.0)


def _recorded_statuses(folder, count: int) -> list[int]:
    """The response statuses recorded in ``folder``, once there are ``count`` of them (60 s
    at most: the server records the exchange when the client has gone)."""
    from plotgate.clients.recordings import read_recording

    deadline = time.monotonic() + 60
    while True:
        statuses = [
            e.response["status"]
            for path in sorted(folder.glob("*.mcap"))
            for e in read_recording(path).exchanges
            if e.response is not None
        ]
        if len(statuses) >= count or time.monotonic() > deadline:
            return statuses
        time.sleep(0.2)


def _cpu_s(pid: int) -> float:
    """The CPU time process ``pid`` has used, s (Linux)."""
    from pathlib import Path

    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_an_in_process_evaluate_stops_when_its_client_goes_away_and_is_recorded_499(tmp_path):
    """The chunks in the server's process stop before the next one once the client has
    gone (the one running finishes), and the exchange is recorded 499
    ``client-disconnected``; the server answers the next request as usual."""
    import httpx

    recordings = tmp_path / "recordings"
    env = {"PLOTGATE_LIMITS": LONG_WORK_LIMITS}  # in one process, past the default cap
    with serve(recordings, env=env, log=tmp_path / "serve.log") as (proc, url):
        _given_up(url)
        assert _recorded_statuses(recordings, 1) == [499]
        time.sleep(5.0)  # the chunk running when the client left finishes
        busy = _cpu_s(proc.pid)
        time.sleep(3.0)
        assert _cpu_s(proc.pid) - busy < 1.0  # idle: no chunk runs any more
        r = httpx.post(url + "/v1/initiation/evaluate", json=BODY, timeout=120)
        assert r.status_code == 200
    from plotgate.clients.recordings import read_recording

    [path] = recordings.glob("*.mcap")
    gone, answered = read_recording(path).exchanges
    assert gone.response["status"] == 499
    assert gone.response["error"]["type"] == "urn:plotgate:problem:client-disconnected"
    assert answered.response["status"] == 200


def test_an_evaluate_on_the_cluster_is_cancelled_when_its_client_goes_away(tmp_path):
    """The request's tasks leave the scheduler once the client has gone (without the
    cancel, a worker would compute them for minutes), and the exchange is recorded 499."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = [_scheduler(port), _worker(address)]
    recordings = tmp_path / "recordings"
    env = {"PLOTGATE_DASK_SCHEDULER": address}
    try:
        with (
            Client(address, timeout="60s") as monitor,
            serve(recordings, env=env, log=tmp_path / "serve.log") as (_, url),
        ):
            monitor.wait_for_workers(1, timeout=120)
            _given_up(url)
            assert _recorded_statuses(recordings, 1) == [499]
            deadline = time.monotonic() + 30
            while _scheduler_tasks(monitor):  # cancelled: forgotten by the scheduler
                assert time.monotonic() < deadline, "the tasks were not cancelled"
                time.sleep(0.2)
    finally:
        for process in processes:
            process.kill()
            process.wait(timeout=30)

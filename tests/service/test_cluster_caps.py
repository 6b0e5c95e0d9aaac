"""Caps on a cluster (issue 29): with a Dask scheduler, a chunked operation's default cap
widens with the worker threads the scheduler reports, up to a hard ceiling; without one,
or past the widened cap, the request is refused at parse with a 422 naming the cap.

The clusters here are LocalClusters of worker threads on 127.0.0.1, started in this
process (about a second). The must-show evaluation (10^4 runs at clutter 250) is checked
for acceptance with its handler cut short; its run on two workers is a bench
(``bench/bench_cluster_caps.py``)."""

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from distributed import LocalCluster
from fastapi.testclient import TestClient

from plotgate.service.app import create_app
from plotgate.service.cluster import cluster, workers
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS, over_caps
from plotgate.service.schemas import (
    CLUSTER_BUDGET_S,
    TIME_BUDGET_S,
    EvaluateRequest,
    EvaluateResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
)
from plotgate.service.table import ENDPOINTS
from tests.support.requests import answer, invalid_input

SIZE = "runs x scans x plots"
EVALUATE = ENDPOINTS["initiation.evaluate"]
SCORE = json.loads((Path(__file__).parents[2] / "docs/examples/score_initiation.json").read_text())
MUST_SHOW = {"config": SCORE, "scenario": {"clutter": 250.0}, "runs": 10_000, "seed": 2026}
"""Mu et al.'s scenario at clutter 250, 10^4 runs: 1.02e7 plots."""
SMALL = {"config": {"mode": "polar", "v_max": 30}, "scenario": {"clutter": 50}, "seed": 2}


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """A scheduler on 127.0.0.1 with two single-threaded workers in this process."""
    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        host="127.0.0.1",
        protocol="tcp",
        dashboard_address=":0",
    ) as local:
        yield local.scheduler_address


def _post(settings: Settings, body: dict) -> "TestClient.post":
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        return c.post("/v1/initiation/evaluate", json=body)


def _cut_short(request: EvaluateRequest) -> EvaluateResult:
    """An answer without the work: the must-show's acceptance, not its minutes."""
    means = {"confirmable": 0.0, "mean_true": 0.0, "se_true": None, "mean_false": 0.0}
    return EvaluateResult(
        runs=request.runs,
        targets=len(request.scenario.targets),
        se_false=None,
        mean_true_by_distance=0.0,
        mean_false_by_distance=0.0,
        mean_time_to_confirmation=None,
        **means,
    )


def test_the_must_show_evaluation_is_over_the_one_core_cap():
    request = EvaluateRequest.model_validate(MUST_SHOW)
    assert request.runs * request.scenario.plots() == 10_200_000
    assert request.work() > EVALUATE.caps[SIZE]
    assert request.work() <= EVALUATE.cluster_cap(SIZE, 2)


def test_without_a_cluster_the_must_show_evaluation_is_refused_naming_the_cap(
    settings, swap_handler
):
    swap_handler("initiation.evaluate", _cut_short)
    problem = invalid_input(_post(settings, MUST_SHOW), SIZE)
    cap = EVALUATE.caps[SIZE]
    assert f"this server allows at most {cap} (the default" in problem["detail"]
    per_thread = cap * round(CLUSTER_BUDGET_S / TIME_BUDGET_S)
    assert "a Dask cluster (PLOTGATE_DASK_SCHEDULER" in problem["detail"]
    assert f"takes {per_thread} per worker thread" in problem["detail"]


def test_with_a_scheduler_the_must_show_evaluation_is_accepted(settings, swap_handler, scheduler):
    swap_handler("initiation.evaluate", _cut_short)
    clustered = settings.model_copy(update={"dask_scheduler": scheduler})
    assert answer(_post(clustered, MUST_SHOW))["runs"] == 10_000


def test_the_cluster_cap_scales_with_the_workers_and_stops_at_the_ceiling():
    default, ceiling = EVALUATE.caps[SIZE], EVALUATE.cluster_caps[SIZE]
    per_thread = EVALUATE.cluster_cap(SIZE, 1)
    assert per_thread == default * round(CLUSTER_BUDGET_S / TIME_BUDGET_S)
    assert EVALUATE.cluster_cap(SIZE, 3) == 3 * per_thread
    assert EVALUATE.cluster_cap(SIZE, 0) == default  # every worker lost: as in-process
    assert EVALUATE.cluster_cap(SIZE, 10**6) == ceiling


@pytest.fixture
def small_caps(monkeypatch, settings) -> Settings:
    """Settings whose evaluate cap is 1000 plot-equivalents (40,000 on two threads, 50,000
    at most): small clustered runs pass the one-core cap."""
    monkeypatch.setitem(EVALUATE.caps, SIZE, 1000)
    monkeypatch.setitem(EVALUATE.cluster_caps, SIZE, 50_000)
    monkeypatch.setattr("plotgate.service.schemas.endpoints.CLUSTER_BUDGET_S", 200.0)
    return settings.model_copy(update={"limits": Settings(record=False).limits})


def test_a_run_past_the_one_core_cap_runs_on_the_cluster_as_it_would_in_process(
    small_caps, scheduler
):
    body = {**SMALL, "runs": 50}
    assert 1000 < EvaluateRequest.model_validate(body).work() <= 40_000
    invalid_input(_post(small_caps, body), SIZE)
    spread = answer(_post(small_caps.model_copy(update={"dask_scheduler": scheduler}), body))
    alone = answer(_post(small_caps.model_copy(update={"limits": {}}), body))
    assert spread == alone


def test_past_the_cluster_cap_the_problem_names_it_and_the_workers(
    small_caps, scheduler, monkeypatch
):
    clustered = small_caps.model_copy(update={"dask_scheduler": scheduler})
    body = {**SMALL, "runs": 70}
    assert 40_000 < EvaluateRequest.model_validate(body).work() <= 50_000
    problem = invalid_input(_post(clustered, body), SIZE)
    detail = problem["detail"]
    assert "at most 40000 (the cluster's cap: 20000 per worker thread x the 2" in detail
    monkeypatch.setitem(EVALUATE.cluster_caps, SIZE, 30_000)
    problem = invalid_input(_post(clustered, body), SIZE)
    assert "at most 30000 (the cluster's cap" in problem["detail"]
    assert "at most 30000, the ceiling" in problem["detail"]


def test_an_operators_cap_is_not_widened_by_a_cluster(settings, scheduler, swap_handler):
    swap_handler("initiation.evaluate", _cut_short)
    operator = Settings(record=False, limits={"initiation.evaluate": {SIZE: 1000}}).limits
    clustered = settings.model_copy(update={"dask_scheduler": scheduler, "limits": operator})
    problem = invalid_input(_post(clustered, {**SMALL, "runs": 50}), SIZE)
    assert "at most 1000 (PLOTGATE_LIMITS)" in problem["detail"]


def test_an_unreachable_scheduler_is_a_503_not_a_422(settings, swap_handler):
    swap_handler("initiation.evaluate", _cut_short)
    lost = settings.model_copy(update={"dask_scheduler": "tcp://127.0.0.1:9"})
    r = _post(lost, MUST_SHOW)
    assert r.status_code == 503 and "retry-after" in r.headers


def test_a_scheduler_without_workers_is_a_503_for_work_past_the_one_core_cap(
    settings, swap_handler
):
    swap_handler("initiation.evaluate", _cut_short)
    with LocalCluster(
        n_workers=0, processes=False, host="127.0.0.1", protocol="tcp", dashboard_address=":0"
    ) as local:
        r = _post(
            settings.model_copy(update={"dask_scheduler": local.scheduler_address}), MUST_SHOW
        )
    assert r.status_code == 503 and "retry-after" in r.headers
    assert "reports no workers" in r.json()["detail"]


def test_the_command_lines_cluster_reports_its_threads(scheduler):
    assert workers() is None
    with cluster(scheduler):
        assert workers() == 2
        caps = Settings(record=False).limits["initiation.evaluate"]
        request = EvaluateRequest.model_validate(MUST_SHOW)
        assert over_caps(OPERATIONS["initiation.evaluate"], request, caps) is None
    assert workers() is None


SIMULATE = ENDPOINTS["identification.simulate"]
BEARINGS = "runs x (n + m)"
LARGE_EXPERIMENT = {"n": 50, "m": 5, "runs": 4_545_454, "seed": 2026}
"""250 million bearings: ten times the one-core cap, 250 chunks on a cluster."""


def _cut_short_experiment(request: IdentifySimulateRequest) -> IdentifySimulateResult:
    """An answer without the draws: the acceptance, not the experiment."""
    return IdentifySimulateResult(runs=request.runs, identified=0, rejected=0, standard_error=0)


def test_an_experiment_past_the_one_core_cap_is_refused_without_a_cluster_and_taken_by_one(
    settings, swap_handler, scheduler
):
    """The experiment draws its bearings in chunks and the service gathers one count a
    chunk, so a cluster widens its cap as it does evaluate's, up to the schema's bound."""
    swap_handler("identification.simulate", _cut_short_experiment)
    assert SIMULATE.caps[BEARINGS] < 250_000_000 <= SIMULATE.cluster_cap(BEARINGS, 2)
    assert SIMULATE.cluster_cap(BEARINGS, 10**6) == SIMULATE.cluster_caps[BEARINGS]
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        r = c.post("/v1/identification/simulate", json=LARGE_EXPERIMENT)
    assert "a Dask cluster (PLOTGATE_DASK_SCHEDULER" in invalid_input(r, BEARINGS)["detail"]
    clustered = settings.model_copy(update={"dask_scheduler": scheduler})
    with TestClient(create_app(clustered), raise_server_exceptions=False) as c:
        r = c.post("/v1/identification/simulate", json=LARGE_EXPERIMENT)
    assert r.status_code == 200, r.text

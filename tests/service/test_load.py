"""A bounded load test on loopback: 50 concurrent clients, a fixed number of requests."""

import json
import threading
from collections import Counter

import httpx

from plotgate.clients.recordings import read_recording
from tests.support.requests import GOOD
from tests.support.servers import serve

CLIENTS, EACH = 50, 12


def test_fifty_clients_every_exchange_recorded_once(tmp_path, mcap_check):
    body = json.dumps(GOOD).encode()
    statuses: Counter[int] = Counter()
    errors: list[str] = []
    lock = threading.Lock()

    def client(k: int, url: str) -> None:
        with httpx.Client(base_url=url, timeout=60) as http:
            for i in range(EACH):
                try:
                    r = http.post(
                        "/v1/gates/test",
                        content=body,
                        headers={"content-type": "application/json", "x-request-id": f"c{k}-{i}"},
                    )
                except httpx.HTTPError as exc:  # pragma: no cover - the failure we test for
                    with lock:
                        errors.append(repr(exc))
                    continue
                with lock:
                    statuses[r.status_code] += 1

    with serve(tmp_path) as (_, url):
        threads = [threading.Thread(target=client, args=(k, url)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=120)
    assert not errors and statuses == {200: CLIENTS * EACH}
    [path] = sorted(tmp_path.glob("*.mcap"))
    rec = read_recording(path)
    assert rec.complete
    requests = Counter(ex.request_id for ex in rec.exchanges)
    responses = Counter(ex.request_id for ex in rec.exchanges if ex.response is not None)
    sent = {f"c{k}-{i}" for k in range(CLIENTS) for i in range(EACH)}
    assert set(requests) == sent and set(requests.values()) == {1}
    assert responses == requests
    assert all(ex.response["status"] == 200 for ex in rec.exchanges)
    code, report = mcap_check(path)
    assert code == 0 and report["total_messages"] == 2 * len(sent)

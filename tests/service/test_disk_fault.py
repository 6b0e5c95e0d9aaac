"""A real disk fault under load: the server may write at most FILE_LIMIT bytes per file
(RLIMIT_FSIZE, so writes past it fail with EFBIG as on a full disk). Nothing it
acknowledges may be missing from the files. A failed write is tried again in a fresh file
at once (which succeeds here, as a full file is the fault); an exchange that cannot be
recorded there either is answered 503."""

import json
import resource
import signal
import threading
from collections import Counter

import httpx

from plotgate.clients.recordings import read_recording
from tests.servers import serve
from tests.service.test_recording import GOOD

FILE_LIMIT = 256 * 1024  # bytes per file; a few hundred exchanges


def _small_files() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a failed write, not a dead process
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT, FILE_LIMIT))


def test_no_acknowledged_exchange_is_lost_when_the_disk_fills(tmp_path):
    body = json.dumps(GOOD).encode()
    answered: list[str] = []
    statuses: Counter[int] = Counter()
    lock = threading.Lock()

    def client(k: int, url: str) -> None:
        with httpx.Client(base_url=url, timeout=60) as http:
            for i in range(150):
                rid = f"c{k}-{i}"
                r = http.post(
                    "/v1/gates/test",
                    content=body,
                    headers={"content-type": "application/json", "x-request-id": rid},
                )
                with lock:
                    statuses[r.status_code] += 1
                    if r.status_code == 200:
                        answered.append(rid)
                    else:
                        assert r.status_code == 503, r.text
                        assert r.json()["type"] == "urn:plotgate:problem:recording-unavailable"

    with serve(tmp_path, preexec_fn=_small_files) as (_, url):
        threads = [threading.Thread(target=client, args=(k, url)) for k in range(10)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=300)
        assert httpx.get(url + "/readyz").status_code == 200  # recovered by itself
        after = httpx.post(
            url + "/v1/gates/test",
            content=body,
            headers={"content-type": "application/json", "x-request-id": "after"},
        )
        assert after.status_code == 200
        answered.append("after")
    assert statuses[200] > 0 and set(statuses) <= {200, 503}
    recorded = {
        ex.request_id
        for f in sorted(tmp_path.glob("*.mcap"))
        for ex in read_recording(f).exchanges
        if ex.response is not None
    }
    missing = set(answered) - recorded
    assert not missing, f"{len(missing)} acknowledged exchanges missing: {sorted(missing)[:5]}"
    assert len(list(tmp_path.glob("*.mcap"))) > 1  # the fault happened: a new file each time

"""A real disk fault under load: the server may write at most FILE_LIMIT bytes per file
(RLIMIT_FSIZE, so writes past it fail with EFBIG as on a full disk). Nothing it
acknowledges may be missing from the files. A failed write is tried again in a fresh file
at once (which succeeds here, as a full file is the fault); an exchange that cannot be
recorded there either is answered 503."""

import json
import resource
import signal
import threading
import time
from collections import Counter

import httpx

from plotgate.clients.recordings import read_recording
from tests.support.requests import GOOD
from tests.support.servers import serve

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


def _no_space() -> None:
    """Every write to a file fails (EFBIG, as ENOSPC on a full disk) until the limit is
    raised from outside with ``prlimit``: creating a file still works, as on a full disk."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, resource.RLIM_INFINITY))


def _read_all(stream, into: list[bytes]) -> None:
    """Everything ``stream`` gives until its end (or until it is closed under the read)."""
    try:
        while chunk := stream.read1(65536):
            into.append(chunk)
    except (OSError, ValueError):
        return


def test_a_full_disk_leaves_no_empty_files_and_recovers_when_space_returns(tmp_path):
    """Refused requests on a full disk used to leave one empty file each (5,723 in 4.5 s),
    which the readers then refused as "not an MCAP file"; and each left "Future exception
    was never retrieved" with a traceback in the server's log (the commit its request
    record scheduled, failed with nobody waiting on it)."""
    body = json.dumps(GOOD).encode()
    headers = {"content-type": "application/json"}
    folder, said = tmp_path / "recordings", []
    with serve(folder, preexec_fn=_no_space) as (proc, url), httpx.Client(base_url=url) as http:
        # the server's log, from its pipe (a log file could not be written: no space)
        reader = threading.Thread(target=_read_all, args=(proc.stderr, said), daemon=True)
        reader.start()
        codes = Counter(
            http.post("/v1/gates/test", content=body, headers=headers).status_code
            for _ in range(50)
        )
        assert codes == {503: 50}
        assert sorted(p.name for p in folder.iterdir()) == []  # nothing left behind
        assert http.get("/readyz").status_code == 503
        resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY,) * 2)
        deadline = time.monotonic() + 30
        while http.get("/readyz").status_code != 200:  # the probe finds the space back
            assert time.monotonic() < deadline, "not ready again 30 s after space returned"
            time.sleep(0.05)
        assert http.post("/v1/gates/test", content=body, headers=headers).status_code == 200
    reader.join(timeout=30)
    log = b"".join(said).decode(errors="replace")
    assert "never retrieved" not in log and "Traceback" not in log, log[-3000:]
    [recording] = folder.glob("*.mcap")
    [exchange] = read_recording(recording).exchanges
    assert exchange.response is not None and exchange.response["status"] == 200

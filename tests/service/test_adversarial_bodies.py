"""Structurally absurd bodies just under the size limit: refused as soon as the bytes
received show it, before anything is parsed, with the server's peak memory under 10 times
the body size (VmHWM from /proc, not a timing) and ``/healthz`` answering within 0.5 s
while each is processed (35 ms on a quiet 2-core machine, 0.14 s beside a loaded one; an
event loop blocked by a body would hold it for the seconds a 60 MiB body takes to
receive); what was received up to the refusal is recorded, and refused alike when
replayed."""

from pathlib import Path

import httpx

from plotgate.clients.recordings import read_recording
from plotgate.service.registry import OPERATIONS, execute
from tests.support.servers import health_watch, serve

SIZE = 60 * 2**20  # just under the 64 MiB default limit
HEALTH_WITHIN_S = 0.5


def _repeat(head: bytes, item: bytes, tail: bytes, size: int = SIZE) -> bytes:
    n = (size - len(head) - len(tail)) // (len(item) + 1)
    return head + b",".join([item] * n) + tail


SHAPES = {  # name: (body, the field its refusal names)
    "empty objects": (_repeat(b'{"gate": [', b"{}", b"]}"), "body"),
    "empty arrays": (_repeat(b'{"candidates": [', b"[]", b"]}"), "body"),
    "zeros": (_repeat(b'{"candidates": [', b"0", b"]}"), "body"),
    "nested": (b"[" * (SIZE // 2) + b"]" * (SIZE // 2), "body"),
    "many keys": (_repeat(b"{", b'"k":0', b"}"), "body"),
    "one string": (b'{"gate": "' + b"a" * (SIZE - 12) + b'"}', "body"),
}


def _status(pid: int, key: str) -> int:
    """A /proc/<pid>/status memory figure (VmHWM, VmRSS), bytes."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
    raise KeyError(key)


def test_absurd_bodies_are_refused_with_bounded_memory_and_a_live_health_check(tmp_path):
    with (
        serve(tmp_path / "recordings") as (proc, url),
        httpx.Client(base_url=url, timeout=120) as http,
    ):
        with health_watch(url, tmp_path) as latencies:
            for name, (body, field) in SHAPES.items():
                r = http.post(
                    "/v1/gates/test",
                    content=body,
                    headers={
                        "content-type": "application/json",
                        "x-request-id": name.replace(" ", "-"),
                    },
                )
                assert r.status_code == 422, (name, r.status_code, r.text[:300])
                assert r.json()["errors"][0]["field"] == field, (name, r.text[:300])
        worst = max(latencies)
        peak = _status(proc.pid, "VmHWM")
    print(f"peak RSS {peak / 2**20:.0f} MiB, /healthz at most {worst * 1e3:.0f} ms")
    assert peak < 10 * SIZE, f"peak RSS {peak / 2**20:.0f} MiB for {SIZE / 2**20:.0f} MiB bodies"
    assert worst < HEALTH_WITHIN_S, f"/healthz took {worst:.3f} s"
    recorded = {
        ex.request_id: ex
        for f in (tmp_path / "recordings").glob("*.mcap")
        for ex in read_recording(f).exchanges
    }
    assert len(recorded) == len(SHAPES)  # refusals of requests that reached an operation
    assert all(ex.response is not None for ex in recorded.values())
    for name, (body, _) in SHAPES.items():  # the part received up to the refusal
        raw = recorded[name.replace(" ", "-")].request["raw"].encode()
        assert len(raw) < len(body) and body.startswith(raw)
        replayed = execute(OPERATIONS["gates.test"], raw)  # refused alike
        assert replayed.status == 422 and replayed.json()["errors"][0]["field"] == "body"

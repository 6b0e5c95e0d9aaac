"""A small large body behind six 17 MB ones: how long it waits for its answer.

One ``plotgate serve`` subprocess (this checkout). Both lanes' workers are started by one
small large body first (a server that has seen a large body). Then six ``gates.pairs``
bodies of 46,000 pairs (16.9 MB) are posted at once, and, once the first of them is being
parsed, a 169 KB one (460 pairs): its wall time from send to answer, and the large ones'.
Before the lanes, one worker took the bodies in arrival order and the 169 KB body waited
9.5 s; the aim is under 2 s.

    nice -n 10 .venv/bin/python bench/bench_lanes.py [--repeats 3]
"""

import argparse
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.service.test_large_bodies import pairs_body  # noqa: E402
from tests.support.servers import serve  # noqa: E402

PATH = "/v1/gates/pairs"
HEADERS = {"content-type": "application/json"}


def _timed(url: str, body: bytes) -> tuple[int, float]:
    started = time.monotonic()
    r = httpx.post(url + PATH, content=body, headers=HEADERS, timeout=600)
    return r.status_code, time.monotonic() - started


def run(repeats: int) -> None:
    large, small = pairs_body(46_000), pairs_body(460)
    print(f"large body {len(large) / 1e6:.1f} MB x 6, small body {len(small) / 1e3:.0f} KB")
    with tempfile.TemporaryDirectory() as tmp, serve(Path(tmp) / "rec", ready_s=300) as (_, url):
        assert _timed(url, small)[0] == 200  # both lanes' workers start
        for _ in range(repeats):
            with ThreadPoolExecutor(7) as pool:
                bigs = [pool.submit(_timed, url, large) for _ in range(6)]
                time.sleep(1.0)  # the large ones are in, the first being parsed
                status, took = pool.submit(_timed, url, small).result()
                done = [f.result() for f in bigs]
            print(
                f"small body: {status} in {took:.2f} s; large bodies: "
                + ", ".join(f"{s} in {t:.1f} s" for s, t in done)
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    run(parser.parse_args().repeats)


if __name__ == "__main__":
    main()

"""plotgate recover: refuses what is not MCAP and leaves it alone; after damaged chunks it
keeps every intact chunk that follows and says what it dropped."""

import io
import json

from fastapi.testclient import TestClient
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk

from plotgate.clients.cli import main
from plotgate.clients.recordings import Reader
from plotgate.clients.recover import recover
from plotgate.service.app import create_app
from tests.support.recordings import chunk_per_exchange
from tests.support.requests import GOOD


def test_a_file_that_is_not_mcap_is_refused_and_left_alone(tmp_path, capsys):
    path = tmp_path / "session.mcap"
    data = json.dumps([{"request_id": "x"}]).encode()
    path.write_bytes(data)
    assert main(["recover", str(path)]) == 2
    err = capsys.readouterr().err
    assert "not an MCAP file" in err and "left as it is" in err
    assert len(err.strip().splitlines()) == 1
    assert path.read_bytes() == data and [p.name for p in tmp_path.iterdir()] == [path.name]
    assert main(["recover", str(tmp_path / "missing.mcap")]) == 2


def test_flipped_bytes_drop_their_chunks_and_keep_every_intact_chunk(
    settings, tmp_path, capsys, mcap_check
):
    with TestClient(create_app(settings)) as c:
        for i in range(120):
            assert (
                c.post("/v1/gates/test", json=GOOD, headers={"x-request-id": f"r{i}"}).status_code
                == 200
            )
    [path] = settings.log_dir.glob("*.mcap")
    chunk_per_exchange(path)
    data = bytearray(path.read_bytes())
    with open(path, "rb") as f:
        chunks = sorted(
            make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset
        )
    # the messages of each chunk, by mcap's own reader, before any damage
    per_chunk = [
        [m for m in breakup_chunk(r) if isinstance(m, Message)]
        for r in StreamReader(io.BytesIO(bytes(data)), emit_chunks=True).records
        if isinstance(r, Chunk)
    ]
    assert len(per_chunk) == len(chunks) > 100
    hit = [0, len(chunks) // 3, 2 * len(chunks) // 3]  # the first holds every channel too
    for k in hit:
        c = chunks[k]
        data[c.chunk_start_offset + c.chunk_length // 2] ^= 0xFF  # one byte of LZ4 data
    path.write_bytes(bytes(data))
    lost = sum(len(per_chunk[k]) for k in hit)
    total = sum(map(len, per_chunk))

    capsys.readouterr()
    assert main(["recover", str(path)]) == 0
    out = capsys.readouterr().out
    copy = path.with_name(f"{path.stem}.recovered.mcap")
    assert f"{total - lost} messages from {len(chunks) - 3} intact chunks" in out
    assert f"dropped: 3 damaged chunks (holding {lost} messages by their indexes)" in out
    for k in hit:
        assert f"offset {chunks[k].chunk_start_offset}: damaged chunk" in out
    assert not path.exists() and path.with_name(path.name + ".partial").exists()

    code, report = mcap_check(copy)
    assert code == 0 and report["total_messages"] == total - lost, report["errors"]
    lost_ids = {json.loads(m.data)["request_id"] for k in hit for m in per_chunk[k]}
    kept = [ex.request_id for ex in Reader([copy]) if ex.request and ex.response]
    assert sorted(kept) == sorted(f"r{i}" for i in range(120) if f"r{i}" not in lost_ids)


def test_recover_never_overwrites_its_source(settings, tmp_path):
    with TestClient(create_app(settings)) as c:
        c.post("/v1/gates/test", json=GOOD)
    [path] = settings.log_dir.glob("*.mcap")
    before = path.read_bytes()
    assert main(["recover", str(path), "--out", str(path)]) == 2
    assert path.read_bytes() == before
    done = recover(path, tmp_path / "copy.mcap")
    assert done.was_complete and done.damage_count == 0 and done.renamed is None
    assert path.exists()

"""``plotgate replay --out`` writes a ``/replay/diff`` foxglove.Log per changed exchange,
which the project's readers take as a scene channel, not as damage."""

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from plotgate.clients.cli import main
from plotgate.clients.recordings import Reader
from tests.support.gate_recordings import moved_recording

pytest.importorskip("foxglove")


@pytest.fixture
def replayed(tmp_path: Path) -> Path:
    """A recording with one number moved by 1e-6 relative, replayed with ``--out``."""
    out = tmp_path / "replayed.mcap"
    assert main(["replay", str(moved_recording(tmp_path / "rec", moved=1e-6)), "--out", str(out)])
    return out


def test_the_diff_log_names_the_changed_path_its_values_and_rule(replayed):
    with replayed.open("rb") as f:
        logs = [
            (schema, channel, message)
            for schema, channel, message in make_reader(f).iter_messages(topics=["/replay/diff"])
        ]
    assert len(logs) == 1  # one changed exchange of four
    schema, channel, message = logs[0]
    assert (schema.name, schema.encoding, channel.message_encoding) == (
        "foxglove.Log",
        "protobuf",
        "protobuf",
    )
    text = message.data  # protobuf strings are their UTF-8 bytes
    assert b"gates.test" in text and b"(replay of r3)" in text
    assert b"statistic[1]: recorded " in text and b"default (--rtol/--atol)" in text


def test_readers_take_the_diff_channel_as_a_scene_channel_not_damage(replayed, capsys, mcap_check):
    code, checked = mcap_check(replayed)  # the independent reader (TypeScript @mcap/core)
    assert code == 0 and checked["total_messages"] == 9, checked  # 4 exchanges and a Log
    reader = Reader(replayed)
    exchanges = list(reader)
    (rec,) = reader.files
    assert len(exchanges) == 4 and rec.damage_count == 0 and rec.scene_messages == 1
    assert main(["inspect", str(replayed), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["files"][0]["damage"] == []
    # the replayed answers are this build's: replaying them again changes nothing
    assert main(["replay", str(replayed)]) == 0
    assert "4 compared: 4 unchanged, 0 changed" in capsys.readouterr().out

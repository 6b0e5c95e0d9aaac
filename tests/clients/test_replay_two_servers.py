"""``plotgate replay --calibrate OUT --server A --server B`` (Twitter's Diffy): the noise
learned from two real servers' disagreement, B made noisy in one field by a test hook."""

import tomllib

from plotgate.clients.cli import main
from tests.support.gate_recordings import moved_recording
from tests.support.servers import serve

NOISE = 3e-7
"""The relative amount the noisy server moves every gate statistic by."""

NOISY_GATES = f'''
"""Test hook (sitecustomize, on the noisy server's PYTHONPATH only): gates.test answers
with every statistic moved by {NOISE} relative."""
import plotgate.service.operations.gates as gates

_exact = gates.test


def _noisy(request):
    answer = _exact(request)
    return answer.model_copy(update={{"statistic": [s * (1 + {NOISE}) for s in answer.statistic]}})


gates.test = _noisy
'''


def test_two_servers_disagreement_is_learned_and_passes_a_replay_against_b(tmp_path, capsys):
    rec = moved_recording(tmp_path / "rec")  # this build's answers: A's
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(NOISY_GATES)
    learned = tmp_path / "learned.toml"
    with (
        serve(tmp_path / "a", ready_s=180) as (_, a),
        serve(tmp_path / "b", env={"PYTHONPATH": str(hook)}, ready_s=180) as (_, b),
    ):
        assert main(["replay", str(rec), "--server", b]) == 1  # the noise fails a plain gate
        capsys.readouterr()
        calibrate = ["replay", str(rec), "--calibrate", str(learned), "--server", a]
        assert main([*calibrate, "--server", b]) == 0
        assert "2 runs, 4 answers compared" in capsys.readouterr().out
        assert main(["replay", str(rec), "--server", b, "--tolerances", str(learned)]) == 0
    (rule,) = tomllib.loads(learned.read_text())["rule"]  # the one noisy field, no other
    assert (rule["operation"], rule["path"]) == ("gates.test", "statistic[*]")
    assert NOISE * 0.9 < rule["rtol"] / 10 <= 2 * NOISE  # ten times the noise, rounded up


def test_a_second_server_without_calibrate_is_a_usage_error(tmp_path, capsys):
    rec = moved_recording(tmp_path / "rec")
    two = ["--server", "http://127.0.0.1:9", "--server", "http://127.0.0.1:9"]
    assert main(["replay", str(rec), *two]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "twice with --calibrate" in err
    learned = str(tmp_path / "l.toml")
    assert main(["replay", str(rec), "--calibrate", learned, *two, *two[:2]]) == 2

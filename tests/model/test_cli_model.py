"""`rap-farm train` and `rap-farm evaluate --no-ray` end to end on a tiny synthetic dataset."""

from pathlib import Path

import pytest
from typer.testing import CliRunner

from rap.cli import app, main
from rap.model.inference.torch_engine import TorchPredictor


def test_train_command_writes_a_loadable_checkpoint(tiny_dataset, tmp_path):
    out = tmp_path / "models" / "tiny.pt"
    res = CliRunner().invoke(app, ["train", str(tiny_dataset), "--out", str(out), "--holdout",
                                   "beta", "--epochs", "1", "--device", "cpu", "--seed", "3",
                                   "--batch-size", "32"])
    assert res.exit_code == 0, res.output
    assert "holdout beta: accuracy" in res.output and f"wrote {out}" in res.output
    p = TorchPredictor.load(out)
    assert p.training["config"]["seed"] == 3 and p.training["holdout"] == "beta"
    wide = tmp_path / "models" / "wide.pt"
    res = CliRunner().invoke(app, ["train", str(tiny_dataset), "--out", str(wide), "--epochs", "1",
                                   "--device", "cpu", "--channels", "8,8,16,16",
                                   "--hidden", "48,24,12"])
    assert res.exit_code == 0, res.output
    assert "channels [8, 8, 16, 16]" in res.output
    assert "hidden [48, 24, 12]" in res.output
    assert TorchPredictor.load(wide).config.channels == (8, 8, 16, 16)
    assert TorchPredictor.load(wide).config.hidden == (48, 24, 12)
    tuned = tmp_path / "models" / "tuned.pt"
    res = CliRunner().invoke(app, ["train", str(tiny_dataset), "--out", str(tuned), "--epochs", "1",
                                   "--device", "cpu", "--init", str(out), "--lr", "1e-4"])
    assert res.exit_code == 0, res.output
    assert f"starting from {out}" in res.output
    init = TorchPredictor.load(tuned).training["init"]
    assert init["path"] == str(out) and init["data_fingerprint"] == p.data_fingerprint
    assert init["command"] == p.training["command"]


def test_evaluate_command_no_ray(tiny_dataset, tmp_path):
    out = tmp_path / "report"
    res = CliRunner().invoke(app, ["evaluate", str(tiny_dataset), "--out", str(out), "--epochs",
                                   "1", "--no-ray", "--device", "cpu", "--no-save-models"])
    assert res.exit_code == 0, res.output
    assert "mean accuracy" in res.output
    assert res.output.count(" epoch 1/1") >= 3  # a progress bar per fold, named
    for name in ("table.md", "table.csv", "folds.json", "crossval.png"):
        assert (out / name).stat().st_size > 0
    assert not (out / "models").exists()
    assert (out / "table.md").read_text().count("\n| ") == 1 + 3 + 1 + 1 + 10  # header, folds, mean; header, bins


@pytest.mark.parametrize("argv, message", [
    (["train", "{missing}"], "no such dataset directory"),
    (["train", "{tiny}", "--holdout", "nope"], "no such assembly"),
    (["train", "{tiny}", "--device", "tpu"], "unknown device"),
    (["train", "{tiny}", "--view", "side"], "view must be one of ['pair', 'pair+crop']"),
    (["train", "{tiny}", "--init", "{missing}"], "no such checkpoint"),
    (["train", "{tiny}", "--channels", "8,16"], "--channels '8,16': 4 positive integers"),
    (["evaluate", "{tiny}", "--channels", "a,b,c,d"], "4 positive integers"),
    (["train", "{tiny}", "--hidden", "64,0,8"], "--hidden '64,0,8': 3 positive integers"),
    (["train", "{tiny}", "--descriptors", "depth,colour"], "--descriptors 'depth,colour': all, none"),
    (["evaluate", "{tiny}", "--descriptors", ""], "--descriptors '': all, none"),
    (["train", "{tiny}", "--init", "rap/data/default_model.pt", "--recipe", "paper"],
     "its network differs from this recipe's in descriptors, head, norm"),
])
def test_cli_errors_are_one_line_with_status_2(argv, message, tiny_dataset, tmp_path, capsys):
    argv = [a.format(missing=tmp_path / "missing", tiny=tiny_dataset) for a in argv]
    with pytest.raises(SystemExit) as exc:
        main(argv + ["--out", str(tmp_path / "m.pt"), "--epochs", "1"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and message in err and "\n" not in err
    assert not (tmp_path / "m.pt").exists()


@pytest.mark.parametrize("argv, message", [
    (["train", "{tiny}", "--holdout", "nope"],
     "--holdout nope: no such assembly in {root} (has: alpha, beta, gamma)"),
    (["train", "{tiny}", "--holdout-family", "castles"],
     "--holdout-family castles: no such family in {root} (has: custom)"),
    (["train", "{tiny}", "--device", "tpu"], "--device 'tpu': unknown device (auto, cpu or cuda)"),
    (["score", "{tiny}/m.pt", "{tiny}", "--device", "tpu"],
     "--device 'tpu': unknown device (auto, cpu or cuda)"),
    (["train", "{tiny}", "--recipe", "fast"], "--recipe 'fast': one of paper, robust"),
    (["evaluate", "{tiny}", "--recipe", "fast"], "--recipe 'fast': one of paper, robust"),
    (["train", "{tiny}", "--init", "rap/data/default_model.pt", "--recipe", "paper"],
     "--init rap/data/default_model.pt: its network differs from this recipe's in descriptors, head, norm "
     "(choose the recipe and options it was trained with)"),
])
def test_cli_names_the_flag_where_the_library_names_the_parameter(argv, message, tiny_dataset,
                                                                  tmp_path, capsys):
    """``rap.model`` raises ``ParameterError`` naming ``holdout``, ``device``, ``recipe``,
    ``init``: the commands show the same line with the flag."""
    if argv[0] == "score":  # a checkpoint to score
        model = tmp_path / "m.pt"
        main(["train", str(tiny_dataset), "--out", str(model), "--epochs", "1", "--device", "cpu"])
        capsys.readouterr()
        argv = [str(model) if a == "{tiny}/m.pt" else a for a in argv]
    argv = [a.format(tiny=tiny_dataset) for a in argv]
    if argv[0] != "score":
        argv += ["--out", str(tmp_path / "out.pt"), "--epochs", "1"]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    root = Path(tiny_dataset).resolve()
    assert exc.value.code == 2 and err == f"rap-farm: error: {message.format(root=root)}\n"


def test_score_command_prints_and_writes_per_family(family_dataset, tmp_path):
    model = tmp_path / "m.pt"
    res = CliRunner().invoke(app, ["train", str(family_dataset), "--out", str(model), "--epochs",
                                   "1", "--device", "cpu", "--recipe", "paper"])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(app, ["score", str(model), str(family_dataset), "--by", "family",
                                   "--out", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    assert "walls" in res.output and "ceiling" in res.output
    import json

    doc = json.loads((tmp_path / "s" / "score.json").read_text())
    assert [r["family"] for r in doc["rows"]][-1] == "all" and doc["rows"][-1]["rows"] == 5 * 96
    assert doc["mirror"] is False
    res = CliRunner().invoke(app, ["score", str(model), str(family_dataset), "--by", "family",
                                   "--mirror", "--out", str(tmp_path / "m")])
    assert res.exit_code == 0, res.output
    mirrored = json.loads((tmp_path / "m" / "score.json").read_text())
    assert mirrored["mirror"] is True and mirrored["rows"][-1]["rows"] == 5 * 96


def test_evaluate_by_family(family_dataset, tmp_path):
    out = tmp_path / "rep"
    res = CliRunner().invoke(app, ["evaluate", str(family_dataset), "--out", str(out), "--epochs",
                                   "1", "--no-ray", "--device", "cpu", "--no-save-models",
                                   "--recipe", "paper"])
    assert res.exit_code == 0, res.output
    # auto: the reference assembly out, then each generated family out
    assert "leave-one-assembly-out" in res.output and "leave-one-family-out" in res.output
    assert "| pegs |" in (out / "table.md").read_text()


def test_checkpoint_carries_its_provenance(family_dataset, tmp_path):
    out = tmp_path / "p.pt"
    res = CliRunner().invoke(app, ["train", str(family_dataset), "--out", str(out), "--epochs",
                                   "1", "--device", "cpu", "--recipe", "paper", "--seed", "4"])
    assert res.exit_code == 0, res.output
    t = TorchPredictor.load(out).training
    assert t["command"].startswith("rap-farm") and t["config"]["seed"] == 4
    assert t["model_config"]["head"] == "class" and t["code_version"]
    c = t["corpus"]
    assert c["rows"] == 5 * 96 and c["schema_version"] == 2 and c["root_seed"] == 2
    assert len(c["training_rows_fingerprint"]) == 64
    assert c["training_rows_fingerprint"] == TorchPredictor.load(out).data_fingerprint


def test_train_interrupted_by_ctrl_c_resumes_with_the_same_command(tiny_dataset, tmp_path,
                                                                   monkeypatch, capsys):
    import rap.model.training.train as training

    out = tmp_path / "m.pt"
    argv = ["train", str(tiny_dataset), "--out", str(out), "--epochs", "2", "--device", "cpu"]
    real = training.train

    def ctrl_c_in_epoch_2(*args, on_step=None, **kw):
        def step(ev):
            if ev.get("epoch") == 2:
                raise KeyboardInterrupt
            on_step(ev)
        return real(*args, on_step=step, **kw)

    monkeypatch.setattr(training, "train", ctrl_c_in_epoch_2)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    state = tmp_path / "m.pt.resume"
    assert exc.value.code == 130 and f"kept in {state}; the same command resumes" in err
    assert state.exists() and not out.exists()
    monkeypatch.setattr(training, "train", real)
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 0, res.output
    assert f"resumed from epoch 1 of 2 ({state})" in res.output
    assert out.exists() and not state.exists()  # the state goes once the checkpoint is saved
    assert TorchPredictor.load(out).training["resume"]["from_epoch"] == 1
    monkeypatch.setattr(training, "train", ctrl_c_in_epoch_2)
    with pytest.raises(SystemExit):
        main(argv)
    assert state.exists()
    capsys.readouterr()

    def ctrl_c_at_once(*args, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(training, "train", ctrl_c_at_once)  # before this run's first epoch
    with pytest.raises(SystemExit):
        main(argv)
    assert f"no epoch was completed in this run; {state} is as it was" in capsys.readouterr().err
    monkeypatch.setattr(training, "train", real)
    res = CliRunner().invoke(app, argv + ["--restart"])  # the state is dropped, not resumed
    assert res.exit_code == 0 and "resumed" not in res.output, res.output
    assert TorchPredictor.load(out).training["resume"]["from_epoch"] == 0 and not state.exists()


def test_train_logs_a_line_per_epoch_when_not_on_a_terminal(tiny_dataset, tmp_path):
    res = CliRunner().invoke(app, ["train", str(tiny_dataset), "--out", str(tmp_path / "m.pt"),
                                   "--epochs", "2", "--device", "cpu"])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if ln.startswith("train epoch")]
    assert [ln.split(":")[0] for ln in lines] == ["train epoch 1/2", "train epoch 2/2"]
    assert all("loss" in ln and "accuracy" in ln for ln in lines)
    assert "━" not in res.output  # no bar drawn into a log


def _copy(dataset, tmp_path):
    import shutil

    return shutil.copytree(dataset, tmp_path / "copy")


def test_score_and_train_count_each_duplicated_key_once_and_say_so(tiny_dataset, tmp_path, capsys):
    """Two shards written again (as two concurrent writers did before the lock): one warning line,
    and every key is one row."""
    import json

    from rap.dataset import shard_files

    ds = _copy(tiny_dataset, tmp_path)
    again = [p for p in shard_files(ds) if p.parent.name == "alpha"]
    for p in again:
        p.with_name(p.stem + "-again.parquet").write_bytes(p.read_bytes())
    model = tmp_path / "m.pt"
    main(["train", str(ds), "--out", str(model), "--epochs", "1", "--device", "cpu"])  # exit 0
    err = capsys.readouterr().err
    warning = (f"rap-farm: warning: {ds}: 48 duplicate rows (48 keys stored more than once); each "
               f"key's first row (by shard path, then row) is used")
    assert warning in err.splitlines()
    assert TorchPredictor.load(model).training["corpus"]["rows"] == 144
    main(["score", str(model), str(ds), "--out", str(tmp_path / "s")])
    assert warning in capsys.readouterr().err.splitlines()
    assert json.loads((tmp_path / "s" / "score.json").read_text())["rows"][-1]["rows"] == 144


@pytest.mark.parametrize("command", ["train", "score"])
def test_a_corrupt_shard_is_one_line_naming_it_with_status_2(command, tiny_dataset, tmp_path,
                                                               capsys):
    from rap.dataset import shard_files

    ds = _copy(tiny_dataset, tmp_path)
    bad = shard_files(ds)[2]
    bad.write_bytes(bad.read_bytes()[:-100])  # truncated
    argv = (["train", str(ds), "--out", str(tmp_path / "m.pt"), "--epochs", "1"]
            if command == "train" else ["score", "rap/data/default_model.pt", str(ds)])
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and "\n" not in err
    assert err.startswith(f"rap-farm: error: {bad}: corrupt shard (")
    assert f"rap-farm check {ds} --quarantine" in err
    assert not (tmp_path / "m.pt").exists()

from pipeline import progress


def test_plain_progress_logs_when_not_a_terminal(monkeypatch, capsys):
    monkeypatch.setattr(progress._Progress, "PLAIN_EVERY_S", 0.0)
    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False)
    with progress.make_progress() as bar:
        task = bar.add_task("train", total=2, psnr="")
        bar.advance(task)
        bar.update(task, psnr="21.5")
        bar.advance(task)
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("train")]
    assert lines[0].startswith("train: 1/2")
    assert lines[-1].startswith("train: 2/2") and "psnr=21.5" in lines[-1]
    assert sum(ln.startswith("train: 2/2") for ln in lines) == 1

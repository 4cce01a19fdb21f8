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


def test_plain_progress_lines_estimate_the_time_left(monkeypatch, capsys):
    """A plain line of an unfinished task with a total says how long is left at the rate so
    far; the last line (done) does not."""
    monkeypatch.setattr(progress._Progress, "PLAIN_EVERY_S", 0.0)
    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False)
    with progress.make_progress() as bar:
        task = bar.add_task("train", total=4)
        bar.advance(task)
        bar.advance(task, 3)
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("train")]
    assert "left)" in lines[0] and "left" not in lines[-1]
    assert progress.time_left(40) == "about 40 s left"
    assert progress.time_left(510) == "about 8.5 min left"
    assert progress.time_left(1800) == "about 30 min left"
    assert progress.time_left(3 * 3600) == "about 3.0 h left"

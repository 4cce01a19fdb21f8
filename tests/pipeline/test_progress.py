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


def test_a_resumed_task_estimates_the_time_left_from_its_own_steps(monkeypatch, capsys):
    """A task added at step 1 500 of 3 000 (a resumed fine-tune) that then takes 100 s for
    500 steps has 200 s left at that rate, not the 50 s that crediting it with the first
    run's 1 500 steps gave."""
    monkeypatch.setattr(progress._Progress, "PLAIN_EVERY_S", 0.0)
    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False)
    with progress.make_progress() as bar:
        task = bar.add_task("finetune", total=3000, completed=1500)
        bar._tasks[task].start_time = 0.0  # added at t = 0, updated at t = 100 s
        monkeypatch.setattr(bar._tasks[task], "_get_time", lambda: 100.0)
        bar.update(task, completed=2000)
    line = next(ln for ln in capsys.readouterr().err.splitlines()
                if ln.startswith("finetune: 2000/3000"))
    assert progress.time_left(200) in line, line  # "about 3.3 min left"

"""Progress in a log file is whole lines, a terminal gets a bar, and no work prints nothing."""

import io

import pytest

from turgorbayes.progress import ProgressLines, progress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


class _Clock:
    """Seconds set by the test."""

    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_a_file_gets_one_line_per_step_and_no_carriage_return(tmp_path):
    # Reference: 7 items are at most 10 steps, so each is reported, on its own line
    log = tmp_path / "run.log"
    with open(log, "w") as f:
        seen = list(progress(range(7), desc="curves", unit="file", file=f))
    text = log.read_text()
    assert seen == list(range(7))
    assert "\r" not in text
    assert text.splitlines() == [f"curves: {i}/7 file ({100 * i / 7:.0f} %), 0 s"
                                 for i in range(1, 8)]


def test_many_steps_give_a_line_per_tenth():
    # Reference: 250 items, a line at each further tenth: after items 25, 50, ..., 250
    out = io.StringIO()
    for _ in progress(range(250), desc="figures", unit="curve", file=out):
        pass
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert [line.split(":")[1].split("/")[0].strip() for line in lines] == [
        str(25 * j) for j in range(1, 11)]


def test_a_run_of_unknown_length_reports_every_interval():
    # Reference: 150 steps of 1 s each, a 60 s interval and no total: lines after 60 and
    # 120 s, and the last one when the run ends
    clock, out = _Clock(), io.StringIO()
    bar = ProgressLines(desc="FE points", unit="pt", file=out, interval=60.0, clock=clock)
    for _ in range(150):
        clock.t += 1.0
        bar.update(1)
    bar.close()
    assert out.getvalue().splitlines() == ["FE points: 60 pt, 60 s", "FE points: 120 pt, 120 s",
                                           "FE points: 150 pt, 150 s"]


def test_manual_updates_in_per_cent_with_a_postfix():
    # sampling's bar: a total of 100 (%), moved by hand, with a postfix
    out = io.StringIO()
    with progress(total=100, desc="sampling to convergence", unit="%", file=out) as bar:
        bar.set_postfix_str("300/1200 steps")
        bar.update(25.0 - bar.n)
        bar.update(100.0 - bar.n)
    assert out.getvalue().splitlines() == [
        "sampling to convergence: 25 %, 0 s, 300/1200 steps",
        "sampling to convergence: 100 %, 0 s, 300/1200 steps"]


@pytest.mark.parametrize("stream", [io.StringIO(), _Terminal()])
def test_no_work_prints_nothing(stream):
    # the user's log held "figures: 0curve [00:00, ?curve/s]" for an empty loop
    assert list(progress([], desc="figures", unit="curve", file=stream)) == []
    with progress(total=0, desc="FE points", file=stream) as bar:
        bar.update(0)
    assert stream.getvalue() == ""


def test_disabled_prints_nothing():
    out = io.StringIO()
    assert list(progress(range(3), desc="curves", enabled=False, file=out)) == [0, 1, 2]
    assert out.getvalue() == ""


def test_a_terminal_gets_a_tqdm_bar():
    # Reference: tqdm redraws its bar with carriage returns; that is what a terminal wants
    term = _Terminal()
    assert list(progress(range(3), desc="curves", unit="file", file=term)) == [0, 1, 2]
    assert "\r" in term.getvalue() and "curves" in term.getvalue()

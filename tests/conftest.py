import numpy as np
import pytest


@pytest.fixture
def rng():
    """A fixed-seed generator: tests are reproducible."""
    return np.random.default_rng(20111014)


@pytest.fixture(scope="session")
def table():
    """The shipped k/(PR) surrogate table (tests that need it skip until it is built)."""
    from turgorbayes import surrogate

    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    return surrogate.load()


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """Make ``--dist loadgroup`` honour ``@pytest.mark.xdist_group`` under pytest >= 9.2.

    pytest-xdist (3.8) groups a worker's tests by appending ``@<group>`` to each item's node
    id (it sets ``item._nodeid``); pytest 9.2 keeps the id in ``item._id``, so the suffix was
    lost and grouped tests were spread over both workers: every process that ran one of them
    recomputed the group's shared caches and module fixtures (e.g. the FE points, the fit
    recovery, a criticism of the hidden-effect block). Here the suffix is added where xdist's
    did not take; nothing changes where it did or without loadgroup.
    """
    if not getattr(config.option, "loadgroup", False):
        return
    # the modules with slow tests first: xdist hands out the groups (the most tests first) and
    # then single tests in collection order, so slow tests collected last ran alone at the end
    # (measured: a 47 s and a 15 s test of tests/workflows kept one process busy 50 s after
    # the other ran out of work). Whole modules move, in their own order (stable sort), so a
    # module's fixtures are still set up once.
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)
    for item in items:
        names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                        for m in item.iter_markers("xdist_group")})
        if not names or "@" in item.nodeid:
            continue
        from _pytest.nodeid import NodeId

        item._id = NodeId.parse(f"{item.nodeid}@{'_'.join(names)}")


@pytest.fixture(scope="session")
def example_fit(tmp_path_factory, table):
    """``turgorbayes fit`` on the bundled example with every default (the README's quick start),
    once per process: ``(folder, printed)``, where ``printed`` is what the command wrote to the
    terminal, stdout and stderr in order. Tests that use it carry
    ``@pytest.mark.xdist_group("example_fit")`` so that one process of ``pytest -n 2`` runs it."""
    import contextlib
    import io

    from turgorbayes.cli import main

    out = tmp_path_factory.mktemp("example_fit") / "turgorbayes_fit"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed), \
            pytest.raises(SystemExit) as exit_info:
        main(["fit", "--out", str(out), "--no-progress"])
    assert exit_info.value.code == 0, printed.getvalue()[-3000:]
    return out, printed.getvalue()

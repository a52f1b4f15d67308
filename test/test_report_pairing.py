"""Each FDI report decided with its bus-voltage grid, in order, whatever order the two topics bring them
(graph/report_pairing.py, what the isolation node runs)."""
from rw_fdi_ros.graph.report_pairing import ReportGridPairing

S = 1_000_000_000   # one FDI period [ns]


def _pairing():
    decided = []
    return ReportGridPairing(S, lambda report, grid: decided.append((report, grid))), decided


def test_a_report_waits_for_its_grid_and_reports_go_out_in_order():
    p, decided = _pairing()
    p.report("r1", 1 * S, awaited=True)
    p.report("r2", 2 * S, awaited=True)
    assert decided == []                      # r1's grid not in yet: r2 waits behind it
    p.grid("g1", 1 * S)
    assert decided == [("r1", "g1")]
    p.grid("g2", 2 * S)
    assert decided == [("r1", "g1"), ("r2", "g2")]
    p.grid("g3", 3 * S)                       # a grid ahead of its report
    p.report("r3", 3 * S, awaited=True)
    assert decided[-1] == ("r3", "g3")


def test_a_lost_grid_is_said_by_the_next_one_and_its_report_goes_without_it():
    p, decided = _pairing()
    p.report("r2", 2 * S, awaited=True)
    p.report("r3", 3 * S, awaited=True)
    p.grid("g3", 3 * S)
    assert decided == [("r2", None), ("r3", "g3")]
    p.grid("g2 late", 2 * S)                  # its report was decided without it: dropped
    assert p.grids == {}


def test_a_new_runs_grids_that_come_before_its_first_report_are_kept():
    """A replay of several runs: the stamps start again, and on a loaded machine the new run's first grids may
    come before its first report (the player runs up to 20 samples ahead). Each is its own report's, not dropped
    as the last run's (the flake of test_engine: one report identified without its grid)."""
    p, decided = _pairing()
    for k in (1, 2, 3):
        p.report(f"a{k}", k * S, awaited=True)
        p.grid(f"ga{k}", k * S)
    for k in (1, 2, 3):                       # run b's grids first
        p.grid(f"gb{k}", k * S)
    for k in (1, 2, 3):
        p.report(f"b{k}", k * S, awaited=True)
    assert decided == [("a1", "ga1"), ("a2", "ga2"), ("a3", "ga3"), ("b1", "gb1"), ("b2", "gb2"), ("b3", "gb3")]


def test_a_new_run_decides_the_last_runs_waiting_reports_with_what_they_have():
    p, decided = _pairing()
    for k in (1, 2):
        p.report(f"a{k}", k * S, awaited=True)
        p.grid(f"ga{k}", k * S)
    p.report("a3", 3 * S, awaited=True)       # its grid never comes
    p.report("b1", 1 * S, awaited=True)
    p.grid("gb1", 1 * S)
    assert decided == [("a1", "ga1"), ("a2", "ga2"), ("a3", None), ("b1", "gb1")]


def test_without_a_grid_publisher_a_report_is_decided_at_once():
    p, decided = _pairing()
    p.report("r1", 1 * S, awaited=False)
    p.grid("g2", 2 * S)
    p.report("r2", 2 * S, awaited=False)
    assert decided == [("r1", None), ("r2", "g2")]


def test_a_runs_lost_first_grid_does_not_lose_the_rest_of_its_grids():
    """A new run is seen by a stamp back at the first period; where that grid is lost, the grid topic follows the
    report topic into the new run instead of filing every later grid under the last run."""
    p, decided = _pairing()
    for k in (1, 2, 3):
        p.report(f"a{k}", k * S, awaited=True)
        p.grid(f"ga{k}", k * S)
    p.report("b1", 1 * S, awaited=True)       # gb1 lost
    p.report("b2", 2 * S, awaited=True)
    p.grid("gb2", 2 * S)
    p.report("b3", 3 * S, awaited=True)
    p.grid("gb3", 3 * S)
    assert decided[3:] == [("b1", None), ("b2", "gb2"), ("b3", "gb3")]


def test_a_copy_of_a_waiting_report_does_not_overtake_the_reports_before_it():
    p, decided = _pairing()
    p.report("r1", 1 * S, awaited=True)
    p.report("r2", 2 * S, awaited=True)
    p.report("r2 copy", 2 * S, awaited=True)
    assert decided == []
    p.grid("g1", 1 * S)
    p.grid("g2", 2 * S)
    assert decided == [("r1", "g1"), ("r2", "g2")]

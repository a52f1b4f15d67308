"""`rw-fdi scenarios`: the shipped scenarios, one line each (name, duration, description)."""
NAME = "scenarios"
HELP = "list the shipped scenarios"
PARENTS = ()


def add_arguments(parser) -> None:
    pass   # it takes no option; build_parser calls it for every verb alike


def main(args) -> int:
    from ...core.mission.scenario import available_scenarios, load_scenario
    for name in available_scenarios():
        s = load_scenario(name)
        print(f"{name:28s} {s.duration:6.0f} s  {s.description}")
    return 0

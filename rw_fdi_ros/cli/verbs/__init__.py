"""The verbs of `rw-fdi`, one module each: NAME, HELP, PARENTS, add_arguments(parser) and main(args) -> int."""

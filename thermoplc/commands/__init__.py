"""One module per `thermoplc` subcommand: `add_parser(sub)` declares its options, `run(args)` hands
them to the library and prints the answer. Loading a module imports only argparse and the shared
option types (`options.py`); the work's imports sit inside `run`, so `thermoplc --version` and
each command's `--help` stay fast."""

"""CLI subcommands: each module has ``add_args(parser)`` and ``run(args) -> int``."""

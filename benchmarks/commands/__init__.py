"""One module per ``bnerr`` subcommand, each with ``register(subparsers)``; see benchmarks.cli."""

"""simbridge benchmarks: each module exposes run() -> list[dict] and prints a table."""

"""yore's benchmarks: run as `python -m benchmarks.<name>`; each writes JSON and PNG."""

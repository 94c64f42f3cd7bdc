"""Real processes on loopback for the tests and the benchmarks."""

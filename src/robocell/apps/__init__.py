"""Command line, 3D view, commander shell, setup assistant, benchmarks."""

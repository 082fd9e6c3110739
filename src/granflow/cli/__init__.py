"""The ``granflow`` command: a thin layer over the public API; ``main(argv)`` returns the exit
code, so every command runs in-process in tests."""

from granflow.cli.app import build_parser, main

__all__ = ["build_parser", "main"]

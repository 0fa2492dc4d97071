"""``python -m armpath``: the command line."""

from armpath.cli import main

main()

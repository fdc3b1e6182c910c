"""``python -m tacreasoner`` is the same as the ``tacreasoner`` command."""

from tacreasoner.cli import main

main()

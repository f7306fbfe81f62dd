"""``python -m auvdock``: the ``auvdock`` command (the same as the console script)."""

from auvdock.cli import main

if __name__ == "__main__":
    main()

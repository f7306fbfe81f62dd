"""``python -m auvdock.cli``: the ``auvdock`` command."""

from auvdock.cli import main

if __name__ == "__main__":
    main()

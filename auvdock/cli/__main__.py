"""``python -m auvdock.cli``: the ``auvdock`` command (as ``python -m auvdock``)."""

from auvdock.__main__ import main

if __name__ == "__main__":
    main()

from auvdock.cli import main

main()

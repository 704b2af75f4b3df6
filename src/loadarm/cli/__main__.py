"""``python -m loadarm.cli``: the same command line as ``loadarm``."""

from loadarm.cli import main

if __name__ == "__main__":
    main()

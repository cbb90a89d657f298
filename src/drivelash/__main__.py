"""``python -m drivelash``: the ``drivelash`` command (the same app as the console script)."""

from drivelash.cli import main

if __name__ == "__main__":
    main()

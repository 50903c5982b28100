"""``python -m vinecli`` entry point."""

from vinecli.cli.app import main

if __name__ == "__main__":
    main()

import sys

from faultlab.cli import main

if __name__ == "__main__":
    sys.exit(main(prog="python -m faultlab"))

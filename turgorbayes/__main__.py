"""``python -m turgorbayes``: the same command line as the ``turgorbayes`` console script."""

from turgorbayes.cli import main

__all__ = []

if __name__ == "__main__":
    main()

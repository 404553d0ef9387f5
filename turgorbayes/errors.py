"""Exception types of turgorbayes.

Every error a user can provoke with bad input is a :class:`TurgorBayesError`; the command
line prints its message and exits with status 2 instead of showing a traceback.
"""

__all__ = ["DataError", "TurgorBayesError"]


class TurgorBayesError(Exception):
    """Base class of all errors raised by turgorbayes for bad input or failed runs."""


class DataError(TurgorBayesError, ValueError):
    """A cell-data file is malformed.

    Parameters
    ----------
    problem : str
        What is wrong, in words ("must be > 0, got -3.0").
    path : str, optional
        The file.
    line : int, optional
        1-based physical line number in the file (the header is line 1 unless comments precede it).
    column : str, optional
        Column name.
    value : str, optional
        The offending raw text.

    The attributes of the same names carry the data, so callers can point at the cell.
    """

    def __init__(self, problem, path=None, line=None, column=None, value=None):
        self.problem = problem
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        self.value = value
        super().__init__(self._format())

    def _format(self):
        where = []
        if self.path is not None:
            where.append(self.path)
        if self.line is not None:
            where.append(f"line {self.line}")
        if self.column is not None:
            where.append(f"column {self.column}")
        prefix = ", ".join(where)
        return f"{prefix}: {self.problem}" if prefix else self.problem

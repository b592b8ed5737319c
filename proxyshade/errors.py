"""Exceptions shared by the whole toolkit.

``UserError`` and its subclasses are problems with what the user gave us (a graph
file, a parameter, an input image): the CLI prints their one-line message and exits
with their ``exit_code`` (2). ``WriteError`` is an output that could not be written (a
full disk, an I/O error): exit code 74 (``EX_IOERR``). Anything else is an internal error
(exit code 1).
"""

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_IO = 74  # sysexits.h EX_IOERR
EXIT_INTERRUPTED = 130  # 128 + SIGINT


class UserError(Exception):
    """Bad input: the message is one line naming the file or node, the field and the fix."""

    exit_code = EXIT_BAD_INPUT


class GraphFileError(UserError):
    """A YAML graph file is malformed."""


class ParamError(UserError):
    """A node parameter has a bad value."""


class NodeInputError(UserError):
    """A node was given inputs it cannot work with."""


class CycleError(UserError):
    """The graph has a cycle; the message names its path."""


class WriteError(UserError):
    """An output or cache file could not be written (disk full, I/O error); nothing partial
    is left at its name. One line naming the file and the system's reason."""

    exit_code = EXIT_IO

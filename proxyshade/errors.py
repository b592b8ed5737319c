"""Exceptions shared by the whole toolkit.

``UserError`` and its subclasses are problems with what the user gave us (a graph
file, a parameter, an input image): the CLI prints their one-line message and exits
with code 2. Anything else is an internal error (exit code 1).
"""


class UserError(Exception):
    """Bad input: the message is one line naming the file or node, the field and the fix."""


class GraphFileError(UserError):
    """A YAML graph file is malformed."""


class ParamError(UserError):
    """A node parameter has a bad value."""


class NodeInputError(UserError):
    """A node was given inputs it cannot work with."""


class CycleError(UserError):
    """The graph has a cycle; the message names its path."""

"""The one error every fic command raises for bad input: printed as one line, exit code 1."""
from __future__ import annotations


class CommandError(Exception):
    """What the user asked cannot be done; the message says why and what to do instead."""

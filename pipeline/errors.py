"""Errors a user can act on."""


class UserError(Exception):
    """A problem with the user's input or workspace.

    The CLI prints the message as one line (no traceback) and exits with status 2.
    The message names the file or option at fault and says what to do.
    """

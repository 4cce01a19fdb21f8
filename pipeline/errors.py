"""Errors a user can act on."""

import os
import shlex


class UserError(Exception):
    """A problem with the user's input or workspace.

    The CLI prints the message as one line (no traceback) and exits with status 2.
    The message names the file or option at fault and says what to do.
    """


def shell_path(path: str | os.PathLike) -> str:
    """A path as it is typed in a command a message suggests: quoted when it holds spaces
    or other characters a shell would split or expand (``'my photos.deflare'``)."""
    return shlex.quote(str(path))

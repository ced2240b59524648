"""The one exception type for mistakes a user can cause; the CLI turns it into one sentence."""


class UserError(Exception):
    """A bad file, option or request: reported as one sentence on stderr, exit code 2, no traceback."""

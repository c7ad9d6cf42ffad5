"""The one exception type for bad user input (scene, files, command line): exit code 2."""


class InputError(Exception):
    """A user error: message names the key or file, the value and what is allowed."""

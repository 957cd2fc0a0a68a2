"""Exceptions a user can cause; the CLI turns each into a one-line message and exit code 2."""


class QuadsimError(Exception):
    """A problem with the user's input or environment, stated so a person can fix it."""


class ConfigError(QuadsimError):
    """A configuration value (vehicle file, rate, setting) is missing or absurd."""


class ScriptError(QuadsimError):
    """A scripted-flight file or scenario name that cannot be used."""

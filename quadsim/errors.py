"""Exceptions a user can cause; the CLI turns each into a one-line message and exit code 2."""


class QuadsimError(Exception):
    """A problem with the user's input or environment, stated so a person can fix it.

    `cli_message`: the same problem as the command line says it, where what to do is one of its
    flags (`--out DIR`); the message itself names what a Python caller passes (`out=`)."""

    def __init__(self, message: str = "", cli_message: str | None = None) -> None:
        super().__init__(message)
        self._cli_message = cli_message

    @property
    def cli_message(self) -> str:
        return str(self) if self._cli_message is None else self._cli_message


class ConfigError(QuadsimError):
    """A configuration value (vehicle file, rate, setting) is missing or absurd."""


class ScriptError(QuadsimError):
    """A scripted-flight file or scenario name that cannot be used."""

"""One module per ``mcnkit`` command; each adds its subparser (``add_*_parser``), whose ``func`` takes the parsed
arguments and returns the exit code.  :mod:`mcnkit.app.main` imports only the module of the command being run."""

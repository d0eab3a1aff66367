"""The application: what runs the library for a person.

:mod:`~mcnkit.app.main` is the ``mcnkit`` entry point and :mod:`mcnkit.app.commands` holds one module per command;
beside them the one loop over a log's frames (:mod:`~mcnkit.app.drive`) and its sinks (:mod:`~mcnkit.app.sinks`),
where a recording goes (:mod:`~mcnkit.app.recording`), run configuration from dataclasses
(:mod:`~mcnkit.app.runconfig`), safe output files (:mod:`~mcnkit.app.outputs`), exit codes
(:mod:`~mcnkit.app.exits`) and the heap setting of long runs (:mod:`~mcnkit.app.heap`).  Nothing in the library
imports this package."""

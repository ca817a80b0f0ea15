"""``python -m keepaway``: the same command line as the ``keepaway`` console script, with its exit codes.

Under ``-m`` CPython (3.11, 3.12) ends a process by SIGINT, whatever exit code it asked for, if a
KeyboardInterrupt left any code run from a string (``exec``/``eval`` of a str: dataclasses', namedtuples'
and numba's generated code) since the last such run, even one a caller caught:
``run_eval_code_obj`` sets ``_PyRuntime.signals.unhandled_keyboard_interrupt`` then, and ``Py_RunMain``
reads it after ``pymain_run_module``. A Ctrl-C during a command's start-up (its modules' imports, its
kernels' loads) so made ``python -m keepaway run`` end with -SIGINT instead of the 130 it exits with
(docs/design.md, "Exit code 130 after an interrupt"). The console script runs as a file, which CPython ends
through ``Py_Exit`` without that check. An empty string run after the command clears the flag, which a
string run resets when it starts; a KeyboardInterrupt that the command itself lets out sets it again.
"""

try:
    from keepaway.cli import main  # inside: a Ctrl-C while the commands load also ends through the flag's reset

    main()
finally:
    exec("")  # noqa: S102 -- clears CPython's flag of a KeyboardInterrupt left by code run from a string

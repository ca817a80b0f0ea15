"""Exit codes every command shares.

``EXIT_INTERRUPTED``: the exit code of a command stopped by Ctrl-C or SIGTERM (which
``runner.launch.interrupt_on_sigterm`` makes alike): 128 + SIGINT, as a shell reports a process that SIGINT
ended. Here, below every package, so that the command line's entry point can answer a Ctrl-C that lands
while it imports the commands' modules, before any of them is loaded.
"""

EXIT_INTERRUPTED = 130

"""rcssserver's UDP text protocol (docs/protocol.md §16), both ways: the front that seats text clients (the
keepaway-0.6 C++ players, any rcssserver client) at our server, and what our players need to play on a real
rcssserver (their socket edge is ``keepaway.agents.rcss_client``). Sans-IO text codecs (``sexp``,
``commands``, ``render``, ``param_text``, ``read``) and the seat's translation (``seat``) apart from the
front's sockets (``front``)."""

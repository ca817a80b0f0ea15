"""rcssserver's UDP text protocol: the front that seats text clients (the keepaway-0.6 C++ players, any
rcssserver client) at our server, and the client edge that seats our players at a real rcssserver
(docs/protocol.md §16). Sans-IO text codecs (``sexp``, ``render``, ``commands``, ``read``) and the socket
edges (``front``) are separate modules."""

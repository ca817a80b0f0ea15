"""``keepaway view`` and ``keepaway render``: watching games in the browser and drawing them to files.

``viewer.frames`` decides what the page is sent (sans-IO: the replay of a game log, live monitor frames),
``viewer.app`` serves the page and its WebSocket (aiohttp), ``viewer.render`` draws an episode of a game
log to a GIF or MP4, ``viewer.cli`` is the command line. Game logs are read by ``server.game_log``.
The web server is the optional extra ``keepaway[view]``.
"""

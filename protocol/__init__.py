"""The contract between server, players, coach and trainer (docs/protocol.md).

Message dataclasses, the msgpack codec with validation, the protocol version, ZeroMQ endpoint helpers
and the server parameter table. Depends on no other package of the project.
"""

from keepaway.protocol.codec import MAX_PAYLOAD_DEPTH, PROTOCOL_VERSION, Message, decode, encode
from keepaway.protocol.endpoints import (
    DEFAULT_MAX_MESSAGE_BYTES,
    DEFAULT_PORTS,
    MONITOR_EPISODE_TOPIC,
    MONITOR_FRAME_TOPIC,
    bind,
    configure,
    connect_endpoint,
    parse_endpoint,
)
from keepaway.protocol.errors import CODEC_ERROR_CODES, ERROR_CODES, ProtocolError
from keepaway.protocol.messages import (
    COACH_TO_SERVER,
    COMMAND_ARGUMENTS,
    MAX_COMMANDS,
    MONITOR_TOPICS,
    PLAYER_TO_SERVER,
    SERVER_TO_COACH,
    SERVER_TO_PLAYER,
    Advice,
    AtomicCommand,
    Bye,
    CoachBye,
    CoachInit,
    CoachInitOk,
    Command,
    EpisodeControl,
    EpisodeEnd,
    Error,
    Frame,
    Fullstate,
    Hear,
    Init,
    InitOk,
    Look,
    LookOk,
    PlayerReport,
    PlayerSaid,
    Reconnect,
    Report,
    See,
    SenseBody,
    Shutdown,
    Start,
    SynchSee,
    Think,
    Waiting,
    decode_for_coach,
    decode_for_player,
    decode_from_coach,
    decode_from_player,
    decode_monitor,
)
from keepaway.protocol.params import (
    CLASSIC,
    CURRENT,
    KEEPAWAY_LAUNCH,
    NOISE_AXIS,
    NOISE_POLAR,
    PARAMETER_SETS,
    KernelParams,
    ServerParams,
    parameter_set,
    with_square_region,
)

__all__ = [
    "Advice", "AtomicCommand", "Bye", "CLASSIC", "COACH_TO_SERVER", "CODEC_ERROR_CODES", "COMMAND_ARGUMENTS",
    "CURRENT", "CoachBye", "CoachInit", "CoachInitOk", "Command", "DEFAULT_MAX_MESSAGE_BYTES",
    "DEFAULT_PORTS", "ERROR_CODES", "EpisodeControl", "EpisodeEnd", "Error", "Frame", "Fullstate", "Hear", "Init",
    "InitOk", "KEEPAWAY_LAUNCH", "KernelParams", "Look", "LookOk", "MAX_COMMANDS", "MAX_PAYLOAD_DEPTH",
    "MONITOR_EPISODE_TOPIC", "MONITOR_FRAME_TOPIC", "MONITOR_TOPICS", "Message", "NOISE_AXIS", "NOISE_POLAR",
    "PARAMETER_SETS", "PLAYER_TO_SERVER", "PROTOCOL_VERSION", "PlayerReport", "PlayerSaid", "ProtocolError",
    "Reconnect", "Report", "SERVER_TO_COACH", "SERVER_TO_PLAYER", "See", "SenseBody", "ServerParams",
    "Shutdown", "Start", "SynchSee", "Think", "Waiting", "bind", "configure", "connect_endpoint", "decode",
    "decode_for_coach", "decode_for_player", "decode_from_coach", "decode_from_player", "decode_monitor", "encode",
    "parameter_set", "parse_endpoint", "with_square_region",
]

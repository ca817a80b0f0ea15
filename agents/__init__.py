"""The Keepaway players: world model, skills, keeper/taker decisions, policies and the player agent.

``PlayerAgent`` (`agents/player.py`) is the transport-free player that ``keepaway player``
(`agents/cli.py`) connects to a server; the numba kernels below it take a batch dimension so the batched
mode can run many players at once.

Names are imported on first use (PEP 562), so loading the command line (``agents.cli``) does not import
numba or the kernels.
"""

from __future__ import annotations

from keepaway.core.exports import lazy_exports

_EXPORTS = {
    "keepaway.agents.belief": ("AgentMemory", "Belief", "belief_from_truth", "empty_belief", "forget_episode",
                      "new_memory"),
    "keepaway.agents.worldmodel": ("WorldModel",),
    "keepaway.agents.config": ("AgentConfig", "GETOPEN_HANDCODED", "GETOPEN_HANDCODED_CONE", "GETOPEN_LEARNED",
                      "GETOPEN_RANDOM", "PASS_EXTERNAL", "PASS_HANDCODED", "PASS_HOLD", "PASS_RANDOM"),
    "keepaway.agents.interception": ("decay_sums",),
    "keepaway.agents.state_vars": ("getopen_state", "getopen_state_size", "pass_state", "pass_state_size"),
    "keepaway.agents.getopen": ("GetOpenScaling", "InputScaling", "net_size", "net_value"),
    "keepaway.agents.keeper": ("NO_PASS_DECISION", "PASS_DECISION_START", "PASS_DECISION_STEP", "execute_pass_action",
                      "handcoded_pass", "keeper_decide"),
    "keepaway.agents.taker": ("taker_decide",),
    "keepaway.agents.policy_file": ("Policy", "PolicyFileError", "getopen_theta_size", "load_policy", "save_policy"),
    "keepaway.agents.player": ("GETOPEN_POLICIES", "PASS_POLICIES", "PassLearner",
                      "PlayerAgent", "compile_kernels", "greedy_pass_factory", "sarsa_config"),
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

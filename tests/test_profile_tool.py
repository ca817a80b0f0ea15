"""``benchmarks/profile.py``'s reading of gdb's symbols and perf's samples (the tool itself needs perf and
gdb, which CI does not have; these are its pure parts, on text in the two tools' formats)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

spec = importlib.util.spec_from_file_location("benchmarks_profile",
                                              Path(__file__).resolve().parent.parent / "benchmarks" / "profile.py")
profile = importlib.util.module_from_spec(spec)
spec.loader.exec_module(profile)

MSYMBOLS = (
    "[ 0] T 0x7f0000001000 _ZN8keepaway6agents12interception6travelB4v253B36c8tJTIeFIjxB2IKSgI4CrvQCltYEAA_3d_3dEdddd"
    " section .text\n"
    "[ 1] T 0x7f0000002000 _ZN8keepaway6server10perception9see_arenaB4v106B40c8tJTIeFIjxB2IKSgI4CrvSCKg1MMf"
    " section .text\n"
    "[ 2] T 0x7f0000000800 NRT_decref section .text\n"
)


def test_numba_symbols_read_back_as_module_and_function():
    assert (profile.readable("_ZN8keepaway6agents12interception6travelB4v253B36c8tJTIeFIjxB2IKSgI4CrvQC")
            == "keepaway.agents.interception.travel")
    assert (profile.readable("_ZN8keepaway6runner7batched11arena_cycleB3v54B36c8tJTI")
            == "keepaway.runner.batched.arena_cycle")
    assert profile.readable("NRT_decref") == "NRT_decref"


def test_an_address_takes_the_symbol_at_or_below_it():
    symbols = profile.SymbolMap(MSYMBOLS)
    assert symbols.name(0x7F0000001000) == "keepaway.agents.interception.travel"
    assert symbols.name(0x7F0000001FFF) == "keepaway.agents.interception.travel"
    assert symbols.name(0x7F0000002010) == "keepaway.server.perception.see_arena"
    assert symbols.name(0x7F0000000900) == "NRT_decref"
    assert symbols.name(0x10) == "?"


def test_flat_samples_are_lines_and_unknown_frames_are_named_from_gdb():
    script = "7f0000001010 [unknown]\n7f0000002020 [unknown]\n7f55 hypot@@GLIBC_2.35+0x1c\n7f0000001020 [unknown]\n"
    counts = profile.flat_profile(profile.samples_of(script, stacks=False), profile.SymbolMap(MSYMBOLS))
    assert counts == {"keepaway.agents.interception.travel": 2, "keepaway.server.perception.see_arena": 1,
                      "hypot@@GLIBC_2.35": 1}


def test_callers_are_the_first_frames_outside_the_function():
    script = ("7f10 __ieee754_hypot_fma\n7f20 hypot@@GLIBC_2.35\n7f0000001010 [unknown]\n7f0000002010 [unknown]\n\n"
              "7f20 hypot@@GLIBC_2.35\n7f0000002010 [unknown]\n\n"
              "7f0000001010 [unknown]\n7f0000002010 [unknown]\n\n")
    samples = profile.samples_of(script, stacks=True)
    assert len(samples) == 3
    callers = profile.callers_of("hypot", samples, profile.SymbolMap(MSYMBOLS))
    assert callers == {"keepaway.agents.interception.travel": 1, "keepaway.server.perception.see_arena": 1}

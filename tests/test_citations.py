"""Every citation in the repository points at something that exists.

Code, tests, benchmarks and docs cite where a rule comes from in one form:

* a section of the project's own docs: ``docs/rules.md §5.2``, ``docs/protocol.md §12, "Coach"`` (a
  heading or a bold paragraph lead inside that section), ``docs/design.md, "Compiled kernels"``; the
  READMEs of ``tests/data`` likewise;
* a file of the public sources the players and the server follow: ``keepaway-0.6 player/BasicPlayer.cc``,
  ``rcssserver src/player.cpp`` (docs/players.md names them without the prefix, in backticks);
* in the Markdown docs, relative links, with their anchors.

Each cited file must exist, each section number and title must be a section of that file, and each
public source path must be one of the files of the keepaway-0.6 players (tjpalmer/keepaway at commit
56acb9e) or of rcssserver 19.0.0 listed below, which ``tools/build-reference-stack.sh`` builds.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import pytest

from repository_files import REPO, read_text, text_files

# The files of the two public source archives a citation may name, by folder.
KEEPAWAY_SOURCES = {
    "": """
        ChangeLog README keepaway.py keepaway.sh
    """,
    "player": """
        ActHandler.cc ActHandler.h BasicPlayer.cc BasicPlayer.h ChangeLog Connection.cc Connection.h
        DemoExtension.cc Formations.cc Formations.h GenericValues.cc GenericValues.h Geometry.cc
        Geometry.h HandCodedAgent.cc HandCodedAgent.h KeepawayPlayer.cc KeepawayPlayer.h
        LinearSarsaAgent.cc LinearSarsaAgent.h Logger.cc Logger.h LoggerDraw.cc LoggerDraw.h
        Makefile Objects.cc Objects.h Parse.cc Parse.h PlayerSettings.cc PlayerSettings.h
        SMDPAgent.h SayMsgDataTypes.h SayMsgDecoder.h SayMsgEncoder.h SayMsgFactory.h SayMsgIDs.h
        SayMsgTypes.h SenseHandler.cc SenseHandler.h ServerSettings.cc ServerSettings.h
        SoccerTypes.cc SoccerTypes.h WorldModel.cc WorldModel.h WorldModelHighLevel.cc
        WorldModelKeepaway.cc WorldModelPredict.cc WorldModelSayMsgFactory.h
        WorldModelSayMsgTypes.cc WorldModelSayMsgTypes.h WorldModelUpdate.cc formations.conf main.cc
        player.conf tiles2.cc tiles2.h
    """,
    "tools": """
        Makefile README README.kwyzipper example.kwy graph.gnuplot hist.cc hist.gnuplot killserver
        kunzip kwyzipper.cc kzip monitor winsum.cc
    """,
}
RCSSSERVER_SOURCES = {
    "": """
        CMakeLists.txt ChangeLog NEWS README.md
    """,
    "src": """
        arm.h audio.cpp audio.h bodysender.cpp bodysender.h client.cpp coach.cpp coach.h compress.h
        csvsaver.cpp csvsaver.h dispsender.cpp dispsender.h field.cpp field.h fullstatesender.cpp
        fullstatesender.h heteroplayer.cpp heteroplayer.h initsender.cpp initsender.h
        initsendercoach.cpp initsendercoach.h initsenderlogger.cpp initsenderlogger.h
        initsendermonitor.cpp initsendermonitor.h initsenderonlinecoach.cpp initsenderonlinecoach.h
        initsenderplayer.cpp initsenderplayer.h landmarkreader.cpp landmarkreader.h leg.cpp leg.h
        logger.cpp logger.h main.cpp monitor.cpp monitor.h mysqlsaver.cpp object.cpp object.h
        observer.h param.h pcombuilder.cpp pcombuilder.h pcomparser.cpp pcomparser.h player.cpp
        player.h player_command_parser.ypp player_command_tok.h player_command_tok.lpp
        playerparam.cpp playerparam.h playerparamtest.cpp random.h rcssexceptions.cpp
        rcssexceptions.h referee.cpp referee.h remoteclient.cpp remoteclient.h resultsaver.cpp
        resultsaver.hpp sender.h serializer.cpp serializer.h serializercoachstdv1.cpp
        serializercoachstdv1.h serializercoachstdv13.cpp serializercoachstdv13.h
        serializercoachstdv14.cpp serializercoachstdv14.h serializercoachstdv7.cpp
        serializercoachstdv7.h serializercoachstdv8.cpp serializercoachstdv8.h
        serializercommonjson.cpp serializercommonjson.h serializercommonstdv1.cpp
        serializercommonstdv1.h serializercommonstdv7.cpp serializercommonstdv7.h
        serializercommonstdv8.cpp serializercommonstdv8.h serializermonitor.cpp serializermonitor.h
        serializeronlinecoachstdv1.cpp serializeronlinecoachstdv1.h serializeronlinecoachstdv13.cpp
        serializeronlinecoachstdv13.h serializeronlinecoachstdv14.cpp serializeronlinecoachstdv14.h
        serializeronlinecoachstdv6.cpp serializeronlinecoachstdv6.h serializeronlinecoachstdv7.cpp
        serializeronlinecoachstdv7.h serializeronlinecoachstdv8.cpp serializeronlinecoachstdv8.h
        serializerplayerstdv1.cpp serializerplayerstdv1.h serializerplayerstdv13.cpp
        serializerplayerstdv13.h serializerplayerstdv14.cpp serializerplayerstdv14.h
        serializerplayerstdv18.cpp serializerplayerstdv18.h serializerplayerstdv5.cpp
        serializerplayerstdv5.h serializerplayerstdv7.cpp serializerplayerstdv7.h
        serializerplayerstdv8.cpp serializerplayerstdv8.h serverparam.cpp serverparam.h
        serverparamtest.cpp stadium.cpp stadium.h stdoutsaver.cpp stdoutsaver.h stdtimer.cpp
        stdtimer.h synctimer.cpp synctimer.h team.cpp team.h timeable.h timer.h types.h utility.cpp
        utility.h version.h visual.h visualsendercoach.cpp visualsendercoach.h
        visualsenderplayer.cpp visualsenderplayer.h weather.cpp weather.h xmlreader.cpp xmlreader.h
        xpmholder.cpp xpmholder.h
    """,
}


def source_paths(listing: dict[str, str]) -> frozenset[str]:
    return frozenset(f"{folder}/{name}" if folder else name
                     for folder, names in listing.items() for name in names.split())


PUBLIC_SOURCES = {"keepaway-0.6": source_paths(KEEPAWAY_SOURCES), "rcssserver": source_paths(RCSSSERVER_SOURCES)}

SECTION_NUMBER = r"§\d+(?:\.\d+)*"
# docs/NAME.md, then optionally section numbers (§5.2, or a list: §1, §2) and a quoted title.
DOC_CITATION = re.compile(
    r"(?<![\w/.-])(?P<doc>(?:docs|tests/data/[\w-]+)/[\w-]+\.md)"
    rf"(?P<numbers>\s+(?:#\s*)?{SECTION_NUMBER}(?:(?:,\s*|\s+and\s+|-){SECTION_NUMBER})*)?"
    r"(?:,\s*(?:#\s*)?\"(?P<title>[^\"]+)\")?")
# What follows docs/NAME.md in a citation written another way: a bare number, an unquoted or
# unseparated title, the word "section".
MALFORMED_TAIL = re.compile(r"\s+(?:#\s*)?(?:\d|\"|``|section\b)|,[ \t]*(?:``|[A-Z][\w':]*(?: [\w':]+)+[)\"])")
PUBLIC_CITATION = re.compile(r"(?<![\w/.-])(?P<source>keepaway-0\.6|rcssserver) (?P<path>[\w./+-]*\w)")
# In docs/players.md, the public sources are named without the prefix, in backticks.
PLAYERS_DOC_SOURCE = re.compile(r"`(?P<path>(?:player|src|tools)/[\w./+-]*\w|keepaway\.sh)`")
MARKDOWN_LINK = re.compile(r"\]\((?P<target>[^)\s#]*)(?:#(?P<anchor>[^)\s]+))?\)")
HEADING = re.compile(r"^(?P<hashes>#{1,6})\s+(?P<text>.+?)\s*#*\s*$")
NUMBERED = re.compile(r"^(?P<number>\d+(?:\.\d+)*)\.?\s+(?P<title>.*)$")
BOLD_LEAD = re.compile(r"^\s*(?:[*-]\s+)?\*\*(?P<title>[^*]+?)\*\*")
FENCE = re.compile(r"^\s*(```|~~~)")


def normalise_title(text: str) -> str:
    """A title as a reader sees it: no Markdown emphasis or code marks, no line breaks or comment marks
    (a title may be wrapped in a docstring or a comment), no final full stop."""
    text = re.sub(r"\s*\n\s*(?:#\s*)?", " ", text)
    text = text.replace("`", "").replace("*", "")
    return re.sub(r"\s+", " ", text).strip().rstrip(".:")


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading (without the -1, -2 suffixes of repeated headings)."""
    text = heading.strip().lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


@dataclass
class Section:
    level: int
    number: str | None
    title: str
    start: int  # line index of the heading
    end: int = 0  # line index of the next heading at the same or a higher level
    leads: list[str] = field(default_factory=list)  # bold paragraph leads directly inside


@dataclass
class Document:
    sections: list[Section]

    def numbered(self, number: str) -> Section | None:
        return next((s for s in self.sections if s.number == number), None)

    def titles_within(self, section: Section | None) -> list[str]:
        """Every heading title and bold lead inside ``section`` (the whole file when None)."""
        inner = [s for s in self.sections
                 if section is None or (section.start <= s.start < section.end)]
        return [s.title for s in inner] + [lead for s in inner for lead in s.leads]


@cache
def document(name: str) -> Document | None:
    path = REPO / name
    if not path.is_file():
        return None
    lines = path.read_text(encoding="utf-8").split("\n")
    sections: list[Section] = []
    fenced = False
    for index, line in enumerate(lines):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if fenced:
            continue
        heading = HEADING.match(line)
        if heading:
            text = heading.group("text")
            numbered = NUMBERED.match(normalise_title(text))
            number, title = (numbered.group("number"), numbered.group("title")) if numbered else (None, text)
            sections.append(Section(len(heading.group("hashes")), number, normalise_title(title), index))
            continue
        lead = BOLD_LEAD.match(line)
        if lead and sections:
            sections[-1].leads.append(normalise_title(lead.group("title")))
    for i, section in enumerate(sections):
        later = [s.start for s in sections[i + 1:] if s.level <= section.level]
        section.end = later[0] if later else len(lines)
    return Document(sections)


def anchors_of(lines: list[str]) -> set[str]:
    """The anchors of a Markdown file's headings, repeated ones numbered as GitHub numbers them."""
    counts: dict[str, int] = {}
    anchors = set()
    fenced = False
    for line in lines:
        if FENCE.match(line):
            fenced = not fenced
        heading = None if fenced else HEADING.match(line)
        if heading:
            base = github_anchor(heading.group("text"))
            anchors.add(f"{base}-{counts[base]}" if base in counts else base)
            counts[base] = counts.get(base, 0) + 1
    return anchors


def line_of(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def has_title(titles: list[str], title: str) -> bool:
    wanted = normalise_title(title).lower()
    return any(candidate.lower().startswith(wanted) for candidate in titles)


def doc_citation_problems(name: Path, text: str) -> list[str]:
    problems = []
    for match in DOC_CITATION.finditer(text):
        where = f"{name}:{line_of(text, match.start())}"
        doc = document(match.group("doc"))
        if doc is None:
            problems.append(f"{where}: {match.group('doc')} does not exist")
            continue
        if (name.suffix != ".md" and not match.group("numbers") and not match.group("title")
                and MALFORMED_TAIL.match(text, match.end())):
            problems.append(f"{where}: write {match.group('doc')} §N or {match.group('doc')}, \"Title\": "
                            f"{text[match.start():match.end() + 30]!r}")
            continue
        section = None
        for number in re.findall(r"§([\d.]+)", match.group("numbers") or ""):
            section = doc.numbered(number)
            if section is None:
                problems.append(f"{where}: {match.group('doc')} has no section {number}")
        title = match.group("title")
        if title and not has_title(doc.titles_within(section), title):
            inside = f" in §{section.number}" if section else ""
            problems.append(f"{where}: {match.group('doc')} has no section \"{normalise_title(title)}\""
                            f"{inside}")
    return problems


def public_source_problems(name: Path, text: str) -> list[str]:
    problems = []
    for match in PUBLIC_CITATION.finditer(text):
        path = match.group("path")
        if "/" not in path and not re.search(r"\.(?:cc|cpp|h|hpp|sh|py)$|^(?:NEWS|README|ChangeLog)$", path):
            continue  # a version or a word, not a file (``rcssserver 19.0.0``, ``rcssserver's``)
        if path not in PUBLIC_SOURCES[match.group("source")]:
            problems.append(f"{name}:{line_of(text, match.start())}: {match.group('source')} has no file {path}")
    if name == Path("docs/players.md"):
        every_source = PUBLIC_SOURCES["keepaway-0.6"] | PUBLIC_SOURCES["rcssserver"]
        for match in PLAYERS_DOC_SOURCE.finditer(text):
            path = match.group("path")
            if path not in every_source and not (REPO / path).exists():
                problems.append(f"{name}:{line_of(text, match.start())}: no public source or repository file "
                                f"{path}")
    return problems


def blanked(match: re.Match) -> str:
    return re.sub(r"[^\n]", " ", match.group(0))


def without_code(text: str) -> str:
    """``text`` with its code blocks and code spans blanked out (same length, same lines)."""
    text = re.sub(r"^(```|~~~).*?^\1", blanked, text, flags=re.MULTILINE | re.DOTALL)
    return re.sub(r"`[^`\n]*`", blanked, text)


def markdown_link_problems(name: Path, text: str) -> list[str]:
    problems = []
    for match in MARKDOWN_LINK.finditer(without_code(text)):
        target, anchor = match.group("target"), match.group("anchor")
        if re.match(r"^[a-z][\w+.-]*:", target):
            continue  # a URL
        path = (REPO / name).parent / target if target else REPO / name
        where = f"{name}:{line_of(text, match.start())}"
        if not path.exists():
            problems.append(f"{where}: link to {target}, which does not exist")
            continue
        if anchor and path.suffix == ".md":
            if anchor not in anchors_of(path.read_text(encoding="utf-8").split("\n")):
                problems.append(f"{where}: {path.relative_to(REPO)} has no heading #{anchor}")
    return problems


# This file writes bad citations on purpose, to test the checks.
FILES = [name for name in text_files() if name != Path("tests/test_citations.py")]


def test_the_repository_has_text_files_to_check():
    assert Path("docs/players.md") in FILES and Path("agents/interception.py") in FILES


@pytest.mark.parametrize("check", [doc_citation_problems, public_source_problems], ids=lambda f: f.__name__)
def test_every_citation_names_a_file_and_a_section_that_exist(check):
    problems = [problem for name in FILES for problem in check(name, read_text(name))]
    assert not problems, "\n".join(problems)


def test_every_markdown_link_of_the_docs_leads_somewhere():
    problems = [problem for name in FILES if name.suffix == ".md"
                for problem in markdown_link_problems(name, read_text(name))]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("citation, problem", [
    ("(docs/rules.md §5.2)", None),
    ("(docs/protocol.md §12, \"Coach\")", None),
    ("(docs/rules.md §2, \"kick\")", None),
    ("(docs/players.md §5.3 step 2)", None),
    ("(docs/rules.md §1, §2)", None),
    ("(docs/rules.md §1-§4)", None),
    ("(docs/rules.md §1-§12)", "no section 12"),
    ("(docs/design.md, \"Compiled kernels\")", None),
    ("(docs/rules.md §99)", "no section 99"),
    ("(docs/protocol.md §12, \"Nowhere\")", "no section \"Nowhere\" in §12"),
    ("(docs/rules.md §2, \"Coach\")", "no section \"Coach\" in §2"),
    ("(docs/nowhere.md §1)", "does not exist"),
    ("(docs/protocol.md 12 \"Coach\")", "write docs/protocol.md §N"),
    ("(docs/design.md, GetOpen inputs)", "write docs/design.md §N"),
    ("(keepaway-0.6 player/BasicPlayer.cc)", None),
    ("(rcssserver src/player.cpp)", None),
    ("rcssserver 19.0.0's", None),
    ("(rcssserver src/nowhere.cpp)", "rcssserver has no file src/nowhere.cpp"),
    ("(keepaway-0.6 player/Nowhere.cc)", "keepaway-0.6 has no file player/Nowhere.cc"),
])
def test_the_checks_tell_a_good_citation_from_a_bad_one(citation, problem):
    found = doc_citation_problems(Path("x.py"), citation) + public_source_problems(Path("x.py"), citation)
    if problem is None:
        assert found == []
    else:
        assert len(found) == 1 and problem in found[0], found

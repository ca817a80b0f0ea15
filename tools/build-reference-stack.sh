#!/bin/bash
# Build the reference stack: rcssserver 19.0.0 and the keepaway-0.6 C++ players, the programs the
# original Keepaway benchmark runs on, at the commits the project compares itself with
# (benchmarks/side_by_side.py, benchmarks/reference_stack.py, tests/data/rcss-behaviour/README.md).
#
# Usage:
#   tools/build-reference-stack.sh [--sources DIR] [--jobs N] PREFIX
#   tools/build-reference-stack.sh --git SERVER_REPO PLAYERS_REPO [--jobs N] PREFIX
#
# With --sources (or KEEPAWAY_REFERENCE_SOURCES=DIR) the sources are the two public archives in DIR,
# each a `git archive` of its commit with one top folder, checked against the checksums below:
#   rcssserver-19.0.0-ce87001.tar.gz   rcsoccersim/rcssserver at ce870013f2c6 (release 19.0.0, LGPL-3.0)
#   keepaway-players-56acb9e.tar.gz    tjpalmer/keepaway at 56acb9e333a1 (the keepaway-0.6 players with
#                                      the UT LinearSarsaAgent, GPL-2.0)
# With --git they are those commits of two git repositories, local or remote (e.g.
# https://github.com/rcsoccersim/rcssserver.git and https://github.com/tjpalmer/keepaway.git).
# PREFIX (or KEEPAWAY_REFERENCE_STACK=PREFIX) is the build directory; the script replaces its
# rcssserver/ and keepaway/ folders and leaves
#   PREFIX/rcssserver/build/rcssserver  and  PREFIX/keepaway/player/keepaway_player,
# which `benchmarks/side_by_side.py --reference PREFIX` plays.
#
# Build dependencies (Debian 12 package names): g++ make cmake flex libfl-dev bison zlib1g-dev
# libboost-system-dev libboost-filesystem-dev libboost-program-options-dev. About two minutes on two
# cores.
#
# The players are built unmodified. The server gets two patches that do not touch the simulation:
# its three UDP sockets bind to 127.0.0.1 instead of every interface, and its random_seed parameter is
# settable on the command line (19.0.0 has the parameter, seeds its generators from it, but does not
# register it, so the seed is always the time).
set -euo pipefail

SERVER_COMMIT=ce870013f2c6b31b9e93774abb2822c2f346c287   # tag rcssserver-19.0.0
PLAYERS_COMMIT=56acb9e333a188cceb81c650e85da493c9ce23b5  # keepaway-0.6 + UT LinearSarsaAgent
SERVER_ARCHIVE=rcssserver-19.0.0-ce87001.tar.gz
PLAYERS_ARCHIVE=keepaway-players-56acb9e.tar.gz
SERVER_SHA256=c084aed79f0e2bb90eac5b94e13adbd36d8dd599553bd9da0f7cffa3d9d70542
PLAYERS_SHA256=2658c6fa1b06bf9509210755ecf9beffc87849c99ac8f84c7a61fe83fd428971

usage() {  # usage EXIT_CODE: the usage lines above, on stdout for --help, else on stderr
  if [ "$1" = 0 ]; then sed -n '6,8p' "$0" | sed 's/^# *//'; else sed -n '6,8p' "$0" | sed 's/^# *//' >&2; fi
  exit "$1"
}

sources=${KEEPAWAY_REFERENCE_SOURCES:-}
server_repo=
players_repo=
jobs=$(nproc)
prefix=${KEEPAWAY_REFERENCE_STACK:-}
while [ $# -gt 0 ]; do
  case "$1" in
    --sources) sources=${2:?--sources needs a directory}; shift 2 ;;
    --git) server_repo=${2:?--git needs two repositories}; players_repo=${3:?--git needs two repositories}
           shift 3 ;;
    --jobs) jobs=${2:?--jobs needs a number}; shift 2 ;;
    -h|--help) usage 0 ;;
    -*) echo "build-reference-stack: unknown option $1" >&2; usage 2 ;;
    *) prefix=$1; shift ;;
  esac
done
[ -n "$prefix" ] || { echo "build-reference-stack: give the build directory (PREFIX)" >&2; usage 2; }
if [ -z "$server_repo" ] && [ -z "$sources" ]; then
  echo "build-reference-stack: give --sources DIR (the two archives) or --git SERVER_REPO PLAYERS_REPO" >&2
  usage 2
fi

missing=
for tool in g++ make cmake flex bison; do
  command -v "$tool" >/dev/null || missing="$missing $tool"
done
if [ -n "$missing" ]; then
  echo "build-reference-stack: missing$missing; on Debian: apt-get install g++ make cmake flex libfl-dev" \
       "bison zlib1g-dev libboost-system-dev libboost-filesystem-dev libboost-program-options-dev" >&2
  exit 1
fi

mkdir -p "$prefix"
prefix=$(cd "$prefix" && pwd)
rm -rf "$prefix/rcssserver" "$prefix/keepaway"
mkdir "$prefix/rcssserver" "$prefix/keepaway"

# snapshot REPO COMMIT DESTINATION: the commit's files, from a local repository or a clone of a remote one
snapshot() {
  local repo=$1 commit=$2 destination=$3 clone
  if [ ! -d "$repo" ]; then
    clone=$(mktemp -d)
    git clone --quiet --bare "$repo" "$clone"
    repo=$clone
  fi
  git -C "$repo" archive "$commit" | tar -x -C "$destination"
  if [ -n "${clone:-}" ]; then rm -rf "$clone"; fi
}

if [ -n "$server_repo" ]; then
  echo "sources: $SERVER_COMMIT of $server_repo, $PLAYERS_COMMIT of $players_repo"
  snapshot "$server_repo" "$SERVER_COMMIT" "$prefix/rcssserver"
  snapshot "$players_repo" "$PLAYERS_COMMIT" "$prefix/keepaway"
else
  sources=$(cd "$sources" && pwd)
  echo "sources: $sources/$SERVER_ARCHIVE, $sources/$PLAYERS_ARCHIVE"
  (cd "$sources" && sha256sum --check --strict - <<EOF
$SERVER_SHA256  $SERVER_ARCHIVE
$PLAYERS_SHA256  $PLAYERS_ARCHIVE
EOF
  )
  tar -xzf "$sources/$SERVER_ARCHIVE" -C "$prefix/rcssserver" --strip-components=1
  tar -xzf "$sources/$PLAYERS_ARCHIVE" -C "$prefix/keepaway" --strip-components=1
fi

# ---- the server: two patches, then a CMake release build ---------------------------------------------
cd "$prefix/rcssserver"
# (1) the player, trainer and online coach sockets bind to 127.0.0.1 (Addr takes the host in host order)
for port in playerPort offlineCoachPort onlineCoachPort; do
  address="rcss::net::Addr( ServerParam::instance().$port()"
  sed -i "s/$address )/$address, 0x7F000001U )/" src/stadium.cpp
done
test "$(grep -c '0x7F000001U' src/stadium.cpp)" = 3
# (2) register server::random_seed (version 999: never sent to clients)
sed -i 's|^    // addParam( "random_seed", M_random_seed, "", 999 );|    addParam( "random_seed", M_random_seed, "", 999 );|' \
    src/serverparam.cpp
grep -q '^    addParam( "random_seed", M_random_seed, "", 999 );' src/serverparam.cpp

mkdir -p build
cd build
echo "configuring rcssserver (build/cmake.log)"
cmake -DCMAKE_BUILD_TYPE=Release .. > cmake.log 2>&1 || { tail -30 cmake.log; exit 1; }
echo "building rcssserver (build/make.log)"
make -j"$jobs" > make.log 2>&1 || { tail -50 make.log; exit 1; }

# ---- the players: unmodified, their own Makefile, -O2 --------------------------------------------------
cd "$prefix/keepaway/player"
echo "building the keepaway players (player/make.log)"
make CFLAGS_OPT=-O2 -j"$jobs" > make.log 2>&1 || { tail -50 make.log; exit 1; }

ls -l "$prefix/rcssserver/build/rcssserver" "$prefix/keepaway/player/keepaway_player"

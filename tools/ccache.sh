# Sourced by tools/test.sh and tools/quickstart.sh: compile through ccache when it is installed
# (tools/install-deps.sh installs it). Sets `cmake_launcher` for the cmake configure line.
# CI builds each run in a fresh clone in another folder: CCACHE_BASEDIR makes the paths under the
# checkout relative, and CCACHE_NOHASHDIR keeps the folder out of the hash of -g objects (the ASan
# pass), so that a clone anywhere hits the same cache. ccache 4 compresses the cache by default.
cmake_launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER= -DCMAKE_C_COMPILER_LAUNCHER=)
if command -v ccache >/dev/null; then
    export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
    export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
    export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
    cmake_launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi

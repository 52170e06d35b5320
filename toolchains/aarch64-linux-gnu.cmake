# Cross build for 64-bit ARM Linux with Debian 12's cross compiler and multiarch arm64 packages
# (scripts/install-deps.sh cross). Libraries come from /usr/lib/aarch64-linux-gnu; headers from
# /usr/include (shared by all architectures) and /usr/include/aarch64-linux-gnu.
#
# Programs (tests, gtest discovery) run through qemu-aarch64 with NO -L: the arm64 dynamic loader and
# libraries are installed by multiarch at their normal paths, and -L /usr/aarch64-linux-gnu would mix
# the cross-toolchain libc with the multiarch one (different versions; threaded programs hang).
# The emulated CPU comes from QEMU_CPU in the environment (cortex-a53: no dot product; max: has it).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Multiarch: find_library/find_package look in <prefix>/lib/aarch64-linux-gnu.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

# Search the host root, but only its arm64 parts: with the library architecture above, /usr/lib/<arch>
# is searched and the amd64 /usr/lib/x86_64-linux-gnu is not. Programs (qemu, python) are host ones.
set(CMAKE_FIND_ROOT_PATH /)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# Keep host pkg-config from handing out amd64 paths.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)

find_program(EF_QEMU_AARCH64 qemu-aarch64 REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR "${EF_QEMU_AARCH64}")

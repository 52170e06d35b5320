# Cross build for 64-bit ARM Linux with Debian 12's cross compiler and multiarch arm64 packages
# (scripts/install-deps.sh cross). Libraries come from /usr/lib/aarch64-linux-gnu; headers from
# /usr/include (shared by all architectures) and /usr/include/aarch64-linux-gnu.
#
# Programs (tests, gtest discovery) run through qemu-aarch64 -L /: the arm64 dynamic loader and
# libraries are installed by multiarch at their normal paths. -L /usr/aarch64-linux-gnu (or
# QEMU_LD_PREFIX set to it, as cross-compiling guides suggest) would take the cross toolchain's ld.so
# (Debian glibc 2.36-8) but the multiarch libc.so.6 (2.36-9+deb12u*): two builds of glibc whose
# private _rtld_global differs, so the first pthread_create spins for ever walking the thread stack
# cache (every program that starts a thread hangs; the others run). The explicit -L / overrides any
# QEMU_LD_PREFIX in the environment.
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
set(CMAKE_CROSSCOMPILING_EMULATOR "${EF_QEMU_AARCH64};-L;/")

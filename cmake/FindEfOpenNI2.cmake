# Finds OpenNI2 from Debian's libopenni2-dev. Its pkg-config file lives in /usr/share/pkgconfig and
# names the non-multiarch /usr/lib, so we search ourselves: headers in /usr/include/openni2 (shared by
# all architectures), the library in the multiarch folder (CMAKE_LIBRARY_ARCHITECTURE picks the arm64
# one in cross builds). Defines EfOpenNI2::OpenNI2.
find_path(EF_OPENNI2_INCLUDE_DIR OpenNI.h PATH_SUFFIXES openni2)
find_library(EF_OPENNI2_LIB OpenNI2)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(EfOpenNI2 REQUIRED_VARS EF_OPENNI2_INCLUDE_DIR EF_OPENNI2_LIB)
if(EfOpenNI2_FOUND AND NOT TARGET EfOpenNI2::OpenNI2)
  add_library(EfOpenNI2::OpenNI2 INTERFACE IMPORTED)
  set_target_properties(EfOpenNI2::OpenNI2 PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${EF_OPENNI2_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${EF_OPENNI2_LIB}")
endif()

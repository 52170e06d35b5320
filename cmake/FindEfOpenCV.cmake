# Finds OpenCV core and imgproc from Debian's libopencv-core-dev and libopencv-imgproc-dev.
# Debian ships OpenCVConfig.cmake only in libopencv-dev, whose arm64 build does not co-install with
# the amd64 one; the core/imgproc -dev packages do, for both architectures. Defines
# EfOpenCV::core_imgproc.
find_path(EF_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
find_library(EF_OPENCV_CORE_LIB opencv_core)
find_library(EF_OPENCV_IMGPROC_LIB opencv_imgproc)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(EfOpenCV REQUIRED_VARS EF_OPENCV_INCLUDE_DIR EF_OPENCV_CORE_LIB EF_OPENCV_IMGPROC_LIB)
if(EfOpenCV_FOUND AND NOT TARGET EfOpenCV::core_imgproc)
  add_library(EfOpenCV::core_imgproc INTERFACE IMPORTED)
  set_target_properties(EfOpenCV::core_imgproc PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${EF_OPENCV_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${EF_OPENCV_IMGPROC_LIB};${EF_OPENCV_CORE_LIB}")
endif()

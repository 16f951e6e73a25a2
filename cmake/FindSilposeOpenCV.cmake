# Finds the OpenCV modules silpose uses from Debian's per-module -dev packages
# (libopencv-core-dev, ...). Debian ships OpenCVConfig.cmake only in the libopencv-dev meta-package,
# which pulls in every module and its dependencies (Qt, VTK, MPI, GPL codecs); this avoids that.
# Defines imported targets SilposeOpenCV::<module> for each requested component.
#
# calib3d: its -dev package drags highgui, Qt and videoio (GPL FFmpeg), so scripts/install-deps.sh
# installs only its runtime library and unpacks the headers of the calib3d, features2d and flann
# -dev packages into /opt/silpose-deps/include/opencv4. A module without its unversioned .so link
# is linked through the runtime's versioned name (libopencv_<module>.so.406).
find_path(SilposeOpenCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
find_path(SilposeOpenCV_EXTRA_INCLUDE_DIR opencv2/calib3d.hpp
  PATHS /opt/silpose-deps/include PATH_SUFFIXES opencv4)
set(_silpose_cv_includes "${SilposeOpenCV_INCLUDE_DIR}")
if(SilposeOpenCV_EXTRA_INCLUDE_DIR AND NOT SilposeOpenCV_EXTRA_INCLUDE_DIR STREQUAL SilposeOpenCV_INCLUDE_DIR)
  list(APPEND _silpose_cv_includes "${SilposeOpenCV_EXTRA_INCLUDE_DIR}")
endif()
set(_silpose_cv_missing "")
foreach(_module IN LISTS SilposeOpenCV_FIND_COMPONENTS)
  find_library(SilposeOpenCV_${_module}_LIBRARY
    NAMES opencv_${_module} libopencv_${_module}.so.406)
  if(_module STREQUAL "calib3d" AND NOT SilposeOpenCV_EXTRA_INCLUDE_DIR)
    list(APPEND _silpose_cv_missing "calib3d (headers)")
  elseif(SilposeOpenCV_${_module}_LIBRARY AND NOT TARGET SilposeOpenCV::${_module})
    add_library(SilposeOpenCV::${_module} UNKNOWN IMPORTED)
    set_target_properties(SilposeOpenCV::${_module} PROPERTIES
      IMPORTED_LOCATION "${SilposeOpenCV_${_module}_LIBRARY}"
      INTERFACE_INCLUDE_DIRECTORIES "${_silpose_cv_includes}")
  elseif(NOT SilposeOpenCV_${_module}_LIBRARY)
    list(APPEND _silpose_cv_missing ${_module})
  endif()
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SilposeOpenCV
  REQUIRED_VARS SilposeOpenCV_INCLUDE_DIR
  REASON_FAILURE_MESSAGE "missing OpenCV modules: ${_silpose_cv_missing} (run scripts/install-deps.sh)")
if(_silpose_cv_missing)
  set(SilposeOpenCV_FOUND FALSE)
endif()

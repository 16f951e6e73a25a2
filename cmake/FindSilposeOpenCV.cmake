# Finds the OpenCV modules silpose uses from Debian's per-module -dev packages
# (libopencv-core-dev, ...). Debian ships OpenCVConfig.cmake only in the libopencv-dev meta-package,
# which pulls in every module and its dependencies (Qt, VTK, MPI, GPL codecs); this avoids that.
# Defines imported targets SilposeOpenCV::<module> for each requested component.
find_path(SilposeOpenCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
set(_silpose_cv_missing "")
foreach(_module IN LISTS SilposeOpenCV_FIND_COMPONENTS)
  find_library(SilposeOpenCV_${_module}_LIBRARY NAMES opencv_${_module})
  if(SilposeOpenCV_${_module}_LIBRARY AND NOT TARGET SilposeOpenCV::${_module})
    add_library(SilposeOpenCV::${_module} UNKNOWN IMPORTED)
    set_target_properties(SilposeOpenCV::${_module} PROPERTIES
      IMPORTED_LOCATION "${SilposeOpenCV_${_module}_LIBRARY}"
      INTERFACE_INCLUDE_DIRECTORIES "${SilposeOpenCV_INCLUDE_DIR}")
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

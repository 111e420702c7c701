# Teem's nrrd library (Debian libteem-dev 1.12): its packaged TeemConfig.cmake points at the
# package's build directory, so this module finds the header and library and defines Teem::teem.
find_path(TEEM_INCLUDE_DIR teem/nrrd.h)
find_library(TEEM_LIBRARY teem)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Teem REQUIRED_VARS TEEM_INCLUDE_DIR TEEM_LIBRARY)
if(Teem_FOUND AND NOT TARGET Teem::teem)
  add_library(Teem::teem UNKNOWN IMPORTED)
  set_target_properties(Teem::teem PROPERTIES IMPORTED_LOCATION "${TEEM_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${TEEM_INCLUDE_DIR}")
endif()
mark_as_advanced(TEEM_INCLUDE_DIR TEEM_LIBRARY)

# nifticlib's NIfTI-1/2 library (Debian libnifti2-dev 3.0.1): its packaged NIFTIConfig.cmake names
# /usr/lib/libznz.so.3.0.0, which the package does not install, so this module finds the header
# and libraries and defines Nifticlib::nifti2.
find_path(NIFTICLIB_INCLUDE_DIR nifti2_io.h PATH_SUFFIXES nifti)
find_library(NIFTICLIB_NIFTI2_LIBRARY nifti2)
find_library(NIFTICLIB_ZNZ_LIBRARY znz)
find_package(ZLIB REQUIRED)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Nifticlib REQUIRED_VARS NIFTICLIB_INCLUDE_DIR NIFTICLIB_NIFTI2_LIBRARY NIFTICLIB_ZNZ_LIBRARY)
if(Nifticlib_FOUND AND NOT TARGET Nifticlib::nifti2)
  add_library(Nifticlib::nifti2 UNKNOWN IMPORTED)
  set_target_properties(Nifticlib::nifti2 PROPERTIES IMPORTED_LOCATION "${NIFTICLIB_NIFTI2_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${NIFTICLIB_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${NIFTICLIB_ZNZ_LIBRARY};ZLIB::ZLIB;m")
endif()
mark_as_advanced(NIFTICLIB_INCLUDE_DIR NIFTICLIB_NIFTI2_LIBRARY NIFTICLIB_ZNZ_LIBRARY)

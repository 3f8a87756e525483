# The Exodus II library as the imported target mchex::exodus, for this build and for the installed
# package (mchexConfig.cmake includes this file too). Debian's libexodusii-dev ships no CMake or
# pkg-config file; its shared library brings its own netCDF, so only the library and its header
# are looked for. A target rather than a path, so that the exported link interface of the static
# mchex::io names no library path of the machine that built it. Sets MCHEX_EXODUS_FOUND.
if(TARGET mchex::exodus)
  set(MCHEX_EXODUS_FOUND TRUE)
  return()
endif()
find_library(EXODUSII_LIBRARY NAMES exoIIv2c)
find_path(EXODUSII_INCLUDE_DIR exodusII.h)
if(EXODUSII_LIBRARY AND EXODUSII_INCLUDE_DIR)
  add_library(mchex::exodus UNKNOWN IMPORTED)
  set_target_properties(mchex::exodus PROPERTIES IMPORTED_LOCATION "${EXODUSII_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${EXODUSII_INCLUDE_DIR}")
  set(MCHEX_EXODUS_FOUND TRUE)
else()
  set(MCHEX_EXODUS_FOUND FALSE)
endif()

# FindSDPA: the SDPA semidefinite-programming library from Debian's libsdpa-dev (bookworm: SDPA 7.3.16).
# libsdpa-dev ships only a static /usr/lib/libsdpa.a (built -fPIC) and the sdpa_*.h headers; the library
# calls MUMPS (sequential build: libmumps-seq-dev), LAPACK and BLAS (the package's make.inc lists them as
# static archives; their shared counterparts link the same symbols). No pkg-config or CMake config exists.
# Defines SDPA::sdpa (SDPA_FOUND, SDPA_INCLUDE_DIR, SDPA_LIBRARY).
find_path(SDPA_INCLUDE_DIR sdpa_call.h)
find_library(SDPA_LIBRARY NAMES libsdpa.a sdpa)
find_library(SDPA_DMUMPS_LIBRARY dmumps_seq)
find_library(SDPA_MUMPS_COMMON_LIBRARY mumps_common_seq)
find_library(SDPA_MPISEQ_LIBRARY mpiseq_seq)
find_library(SDPA_PORD_LIBRARY pord_seq)
find_package(LAPACK QUIET)
find_package(Threads QUIET)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SDPA
  REQUIRED_VARS SDPA_LIBRARY SDPA_INCLUDE_DIR SDPA_DMUMPS_LIBRARY SDPA_MUMPS_COMMON_LIBRARY SDPA_MPISEQ_LIBRARY
                SDPA_PORD_LIBRARY LAPACK_FOUND Threads_FOUND
  REASON_FAILURE_MESSAGE "install libsdpa-dev (scripts/install-deps.sh)")

if(SDPA_FOUND AND NOT TARGET SDPA::sdpa)
  add_library(SDPA::sdpa UNKNOWN IMPORTED)
  set_target_properties(SDPA::sdpa PROPERTIES
    IMPORTED_LOCATION "${SDPA_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${SDPA_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${SDPA_DMUMPS_LIBRARY};${SDPA_MUMPS_COMMON_LIBRARY};${SDPA_MPISEQ_LIBRARY};${SDPA_PORD_LIBRARY};LAPACK::LAPACK;Threads::Threads")
endif()
mark_as_advanced(SDPA_INCLUDE_DIR SDPA_LIBRARY SDPA_DMUMPS_LIBRARY SDPA_MUMPS_COMMON_LIBRARY SDPA_MPISEQ_LIBRARY
                 SDPA_PORD_LIBRARY)

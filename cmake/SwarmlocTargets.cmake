# Warnings and sanitizers travel as INTERFACE targets linked PRIVATE, so they never leak to consumers.
# Tests and benchmarks take the base set; product code (libraries and apps) also -Wconversion
# -Wsign-conversion. Tests compare sizes with literals and index with ints all over, where a cast per
# assertion would hide what is asserted.
add_library(swarmloc_test_warnings INTERFACE)
target_compile_options(swarmloc_test_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wdouble-promotion $<$<BOOL:${SWARMLOC_WERROR}>:-Werror>)
add_library(swarmloc_warnings INTERFACE)
target_link_libraries(swarmloc_warnings INTERFACE swarmloc_test_warnings)
target_compile_options(swarmloc_warnings INTERFACE -Wconversion -Wsign-conversion)

add_library(swarmloc_sanitizers INTERFACE)
if(SWARMLOC_SANITIZERS)
  # GCC 12 at -O1 with -fsanitize reports a moved-from empty std::optional's payload as maybe uninitialized
  # (a false positive; the release build keeps -Wmaybe-uninitialized as an error).
  target_compile_options(swarmloc_sanitizers INTERFACE -fsanitize=${SWARMLOC_SANITIZERS} -fno-omit-frame-pointer
                                                       -Wno-maybe-uninitialized)
  target_link_options(swarmloc_sanitizers INTERFACE -fsanitize=${SWARMLOC_SANITIZERS})
endif()

# swarmloc_library(NAME <lib> DEPS <targets...>)
# Builds common/<lib>/src/*.cpp into swarmloc_<lib> with public headers in common/<lib>/include.
function(swarmloc_library)
  cmake_parse_arguments(ARG "" "NAME" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${ARG_NAME}/src/*.cpp)
  add_library(swarmloc_${ARG_NAME} STATIC ${sources})
  add_library(swarmloc::${ARG_NAME} ALIAS swarmloc_${ARG_NAME})
  target_include_directories(swarmloc_${ARG_NAME}
                             PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/${ARG_NAME}/include>
                                    $<INSTALL_INTERFACE:include>
                             PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/${ARG_NAME}/src)
  set_target_properties(swarmloc_${ARG_NAME} PROPERTIES EXPORT_NAME ${ARG_NAME})
  target_link_libraries(swarmloc_${ARG_NAME} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS} swarmloc_warnings swarmloc_sanitizers)
endfunction()

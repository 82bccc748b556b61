# The layer rule (docs/architecture.md): each folder may include the swarmloc headers of the libraries
# listed for it and no others, declares only its own namespace (swarmloc::<library>, and namespaces
# nested in it), and names no other library's namespace than those it may use. Run at configure time and
# as the `layers` test:
#   cmake -DSWARMLOC_SOURCE_DIR=<repo> -P cmake/CheckLayers.cmake
# A violation names the file, the header or namespace and the folder's allowed libraries, and fails.
cmake_policy(SET CMP0057 NEW)
if(NOT SWARMLOC_SOURCE_DIR)
  set(SWARMLOC_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR}/..)
endif()

set(layer_core core)
set(layer_models core models)
set(layer_estimators core models estimators)
set(layer_config core models estimators config)
# An agent's runtime and the world it lives in do not see each other: what crosses is the manifest, which
# run prepares from the world.
set(layer_runtime core models estimators config runtime)
set(layer_world core models estimators config world)
set(layer_run core models estimators config runtime world run)
set(layer_rundir core models estimators config runtime world rundir)
set(layer_sim core models estimators config runtime world run rundir sim)
# The transport knows the sample envelope and the scenario's DDS keys, never the world or a simulator.
set(layer_dds core models estimators config runtime dds)
# An agent process knows what a real agent knows: its manifest, its estimator and the transport.
set(layer_agent core models estimators config runtime dds)
set(layer_orchestrator core models estimators config runtime world run rundir sim dds)
# The papers' experiments may use every library; no other folder may use research.
set(layer_research core models estimators config runtime world run rundir sim dds research)
set(libraries core models estimators config runtime world run rundir sim dds research)

set(layer_folders
    core common/core models common/models estimators common/estimators config common/config runtime
    common/runtime world common/world run common/run rundir common/rundir sim common/sim dds common/dds agent
    agent orchestrator orchestrator research research)
string(REPLACE ";" "|" library_alternatives "${libraries}")

set(violations "")
list(LENGTH layer_folders pair_count)
math(EXPR last "${pair_count} - 1")
foreach(index RANGE 0 ${last} 2)
  list(GET layer_folders ${index} layer)
  math(EXPR folder_index "${index} + 1")
  list(GET layer_folders ${folder_index} folder)
  file(GLOB_RECURSE sources ${SWARMLOC_SOURCE_DIR}/${folder}/*.cpp ${SWARMLOC_SOURCE_DIR}/${folder}/*.hpp)
  string(REPLACE ";" " " allowed "${layer_${layer}}")
  foreach(source ${sources})
    file(RELATIVE_PATH relative ${SWARMLOC_SOURCE_DIR} ${source})
    file(STRINGS ${source} includes REGEX "^#include \"swarmloc/[a-z0-9_]+/")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"swarmloc/([a-z0-9_]+)/.*" "\\1" library "${line}")
      if(NOT library IN_LIST layer_${layer})
        string(APPEND violations "  ${relative}: includes swarmloc/${library}/ (${folder} may use: ${allowed})\n")
      endif()
    endforeach()
    # Namespaces follow folders: a folder declares swarmloc::<its layer> (and namespaces inside it).
    file(STRINGS ${source} declarations REGEX "namespace swarmloc::[a-z0-9_]+")
    foreach(line ${declarations})
      string(REGEX REPLACE ".*namespace swarmloc::([a-z0-9_]+).*" "\\1" declared "${line}")
      if(NOT declared STREQUAL layer)
        string(APPEND violations "  ${relative}: declares namespace swarmloc::${declared} (${folder} is swarmloc::${layer})\n")
      endif()
    endforeach()
    # ... and a folder names only the namespaces of the libraries it may use (code and comments alike).
    file(STRINGS ${source} uses REGEX "(^|[^A-Za-z0-9_])(${library_alternatives})::")
    foreach(line ${uses})
      string(REGEX MATCHALL "(^|[^A-Za-z0-9_])(${library_alternatives})::" names "${line}")
      foreach(name ${names})
        string(REGEX REPLACE ".*(${library_alternatives})::$" "\\1" named "${name}")
        if(NOT named IN_LIST layer_${layer})
          string(APPEND violations "  ${relative}: names ${named}:: (${folder} may use: ${allowed})\n")
        endif()
      endforeach()
    endforeach()
  endforeach()
endforeach()

if(violations)
  message(FATAL_ERROR "Layer rule broken (docs/architecture.md):\n${violations}")
endif()

# The layer order of dome's libraries and the check that holds the build to it.
#
# DOME_LAYERS lists the libraries bottom to top (target dome_<name>, folder common/<name>
# or the program's folder: scheduler = master/, worker = worker/, capture_agent =
# capture-agent/, cli = cli/). A library may link and include only libraries before it;
# tests/layers checks the includes, dome_check_layers() below the links. The algorithm
# libraries (DOME_ALGORITHMS) hold no generated protobuf type: wire and file formats are
# converted at the edges (schema, net, ingest, pipeline and the programs).
set(DOME_LAYERS
  core geometry io video schema take silhouette eval capture synth calib fusion mesh sequence stereo view
  net ingest pipeline scheduler worker capture_agent cli)
set(DOME_ALGORITHMS core geometry io video take silhouette eval capture synth calib fusion mesh sequence stereo
  view)
# The master and the worker are peers on the wire: neither links or includes the other
# (the embedded cluster of cli/ links both).
set(DOME_PEERS scheduler worker)

# dome_check_layers(LAYERS name... ALGORITHMS name... PEERS name...): fails the configure
# step, naming both targets, when a library links one at or above it, a peer links
# another peer, or an algorithm library links the generated protobuf library (dome_proto).
function(dome_check_layers)
  cmake_parse_arguments(ARG "" "" "LAYERS;ALGORITHMS;PEERS" ${ARGN})
  list(TRANSFORM ARG_LAYERS PREPEND dome_ OUTPUT_VARIABLE targets)
  foreach(target IN LISTS targets)
    if(NOT TARGET ${target})
      message(FATAL_ERROR "layers: ${target} is in the layer order but is not a target")
    endif()
    list(FIND targets ${target} level)
    get_target_property(links ${target} LINK_LIBRARIES)
    if(NOT links)
      set(links "")
    endif()
    string(REGEX REPLACE "^dome_" "" name ${target})
    foreach(link IN LISTS links)
      if(link STREQUAL "dome_proto")
        if(name IN_LIST ARG_ALGORITHMS)
          message(FATAL_ERROR "layers: ${target} links dome_proto, but an algorithm library "
                              "holds no generated protobuf type (cmake/layers.cmake)")
        endif()
      elseif(link MATCHES "^dome_")
        string(REGEX REPLACE "^dome_" "" link_name ${link})
        if(name IN_LIST ARG_PEERS AND link_name IN_LIST ARG_PEERS)
          message(FATAL_ERROR "layers: ${target} links ${link}: peers on the wire link "
                              "neither each other (cmake/layers.cmake)")
        endif()
        list(FIND targets ${link} link_level)
        if(link_level LESS 0 OR NOT link_level LESS level)
          message(FATAL_ERROR "layers: ${target} links ${link}, which is not below it in "
                              "the layer order (cmake/layers.cmake)")
        endif()
      endif()
    endforeach()
  endforeach()
endfunction()

# cmake -DIN=swarmloc.idl -DOUT=derived.idl -P derive_idl.cmake
# Renames the members fastddsgen cannot parse (see CMakeLists.txt); fails if a rename no longer applies,
# so a change to the IDL is noticed here instead of producing a silently different type.
file(READ "${IN}" idl)
set(renames "Header header=>Header hdr" "Sym2 information=>Sym2 information_matrix")
foreach(rename IN LISTS renames)
  string(REPLACE "=>" ";" pair "${rename}")  # "from=>to" -> list (from, to)
  list(GET pair 0 from)
  list(GET pair 1 to)
  string(FIND "${idl}" "${from}" found)
  if(found EQUAL -1)
    message(FATAL_ERROR "derive_idl: '${from}' is no longer in ${IN}; update derive_idl.cmake")
  endif()
  string(REPLACE "${from}" "${to}" idl "${idl}")
endforeach()
file(WRITE "${OUT}" "${idl}")

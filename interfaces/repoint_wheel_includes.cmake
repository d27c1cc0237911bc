# Passed to the interface build as -DCMAKE_PROJECT_INCLUDE (scripts/build-interfaces).
#
# The ROS 2 wheels from PyPI export CMake targets whose INTERFACE_INCLUDE_DIRECTORIES name the
# Python and NumPy headers of the machine that built the wheels (/opt/python/cp311-cp311/...).
# CMake refuses an imported target whose include directory does not exist, so at the end of the
# configure step every imported target of the project is re-pointed at this interpreter's
# headers (Python3_EXECUTABLE). Nothing installed in the venv is edited.

if(NOT Python3_EXECUTABLE)
  message(FATAL_ERROR "repoint_wheel_includes.cmake: pass -DPython3_EXECUTABLE=<venv python>")
endif()
execute_process(
  COMMAND "${Python3_EXECUTABLE}" -c
    "import sysconfig, numpy; print(sysconfig.get_paths()['include'] + ';' + numpy.get_include(), end='')"
  OUTPUT_VARIABLE _abb_headers
  RESULT_VARIABLE _abb_status)
if(NOT _abb_status EQUAL 0)
  message(FATAL_ERROR "repoint_wheel_includes.cmake: ${Python3_EXECUTABLE} has no numpy")
endif()
list(GET _abb_headers 0 ABB_PYTHON_INCLUDE)
list(GET _abb_headers 1 ABB_NUMPY_INCLUDE)

function(abb_repoint_wheel_includes)
  get_directory_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs OR NOT dirs MATCHES "/opt/python/")
      continue()
    endif()
    set(fixed "")
    foreach(dir IN LISTS dirs)
      if(dir MATCHES "^/opt/python/[^/]+/include/python3")
        list(APPEND fixed "${ABB_PYTHON_INCLUDE}")
      elseif(dir MATCHES "^/opt/python/.*/numpy/(_core|core)/include$")
        list(APPEND fixed "${ABB_NUMPY_INCLUDE}")
      else()
        list(APPEND fixed "${dir}")
      endif()
    endforeach()
    list(REMOVE_DUPLICATES fixed)
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL abb_repoint_wheel_includes)

# CMake toolchain file for packages built on the ROS 2 wheels (rosbook/launch/interfaces_build.py
# names it in CMAKE_TOOLCHAIN_FILE). The venv is the ROS prefix; two things differ from a
# full install, and this file mends them:
#
# * The wheels' CMake exports of their Python type supports name the include folders of
#   the machine that built the wheels (/opt/python/cpXY-cpXY/include/pythonX.Y and numpy's
#   include folder under it). CMake refuses an imported target that names a folder that does
#   not exist, at generate time: at the end of the top-level CMakeLists.txt, every imported
#   target's include folders are pointed at this interpreter's (ROSBOOK_PYTHON_INCLUDE and
#   ROSBOOK_NUMPY_INCLUDE in the environment).
# * The linters a new ament_cmake package runs when BUILD_TESTING is on (ament_lint_auto,
#   ament_lint_common) have no wheel: BUILD_TESTING defaults to off (-DBUILD_TESTING=ON
#   still turns it on).

set(BUILD_TESTING OFF CACHE BOOL "Build the tests (the ament linters have no wheel)")

function(_rosbook_wheel_include_folders)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(folders ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(folders)
      list(TRANSFORM folders REPLACE "^/opt/python/[^/]+/include/python3\\.[0-9]+$"
        "$ENV{ROSBOOK_PYTHON_INCLUDE}")
      list(TRANSFORM folders REPLACE "^/opt/python/.*/numpy/_core/include$"
        "$ENV{ROSBOOK_NUMPY_INCLUDE}")
      set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${folders}")
    endif()
  endforeach()
endfunction()

if(NOT CMAKE_PROJECT_NAME STREQUAL "CMAKE_TRY_COMPILE")
  cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _rosbook_wheel_include_folders)
endif()

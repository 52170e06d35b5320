# The version of this build, from git describe (issue 32): the program prints it (`edgefusion
# version`) and the packages carry it, so that a board's binary names the commit it was built from.
#   a tag vX.Y.Z on HEAD          X.Y.Z
#   N commits after tag vX.Y.Z    X.Y.Z+N.gHASH
#   no such tag                   PROJECT_VERSION+gitN.gHASH (N: commits in the history, so that
#                                 later builds sort later for dpkg)
#   uncommitted changes           the above + ".dirty"
#   no git (a source tarball)     PROJECT_VERSION
# Every form starts with a digit and uses only [0-9A-Za-z.+~], as a Debian upstream version must.
# Sets EF_VERSION in the caller's scope. Computed when CMake configures; a commit re-runs the
# configuration (HEAD and its branch are configure dependencies).
function(ef_compute_version)
  set(version "${PROJECT_VERSION}")
  find_package(Git QUIET)
  if(GIT_FOUND AND EXISTS "${PROJECT_SOURCE_DIR}/.git")
    execute_process(COMMAND "${GIT_EXECUTABLE}" describe --tags --match "v[0-9]*" --long --dirty
                    WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}" OUTPUT_VARIABLE desc RESULT_VARIABLE rc
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(rc EQUAL 0 AND desc MATCHES "^v([0-9][0-9A-Za-z.]*)-([0-9]+)-g([0-9a-f]+)(-dirty)?$")
      set(version "${CMAKE_MATCH_1}")
      set(dirty "${CMAKE_MATCH_4}")
      if(NOT CMAKE_MATCH_2 STREQUAL "0")
        string(APPEND version "+${CMAKE_MATCH_2}.g${CMAKE_MATCH_3}")
      endif()
    else()
      execute_process(COMMAND "${GIT_EXECUTABLE}" rev-list --count HEAD
                      WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}" OUTPUT_VARIABLE count RESULT_VARIABLE rc1
                      OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
      execute_process(COMMAND "${GIT_EXECUTABLE}" describe --always --abbrev=7 --dirty
                      WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}" OUTPUT_VARIABLE hash RESULT_VARIABLE rc2
                      OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
      if(rc1 EQUAL 0 AND rc2 EQUAL 0 AND hash MATCHES "^([0-9a-f]+)(-dirty)?$")
        set(version "${PROJECT_VERSION}+git${count}.g${CMAKE_MATCH_1}")
        set(dirty "${CMAKE_MATCH_2}")
      endif()
    endif()
    if(dirty)
      string(APPEND version ".dirty")
    endif()
    # Re-run the configuration when HEAD moves (a commit or a checkout).
    set(deps "${PROJECT_SOURCE_DIR}/.git/HEAD")
    execute_process(COMMAND "${GIT_EXECUTABLE}" rev-parse --symbolic-full-name HEAD
                    WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}" OUTPUT_VARIABLE ref
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(ref AND EXISTS "${PROJECT_SOURCE_DIR}/.git/${ref}")
      list(APPEND deps "${PROJECT_SOURCE_DIR}/.git/${ref}")
    endif()
    set_property(DIRECTORY "${PROJECT_SOURCE_DIR}" APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${deps})
  endif()
  set(EF_VERSION "${version}" PARENT_SCOPE)
endfunction()

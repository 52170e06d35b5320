# Open3D reads our surfel PLY as a user's tool would (Debian's python3-open3d, installed by
# scripts/install-deps.sh test). Included by tests/CMakeLists.txt for native builds only.
# ply_open3d_write runs the fixture program; ply_open3d_read (requires it) runs the Python check,
# which fails (never skips) when open3d cannot be imported.
add_executable(ply_fixture "${CMAKE_CURRENT_LIST_DIR}/ply_fixture.cpp")
target_link_libraries(ply_fixture PRIVATE ef_io)
ef_target_warnings(ply_fixture)

set(EF_PLY_FIXTURE_FILE "${CMAKE_CURRENT_BINARY_DIR}/ply_open3d/fixture.ply")
add_test(NAME ply_open3d_write COMMAND ply_fixture "${EF_PLY_FIXTURE_FILE}")
set_tests_properties(ply_open3d_write PROPERTIES FIXTURES_SETUP ply_open3d_file TIMEOUT 60)
add_test(NAME ply_open3d_read
         COMMAND /usr/bin/python3 "${CMAKE_CURRENT_LIST_DIR}/check_ply_open3d.py" "${EF_PLY_FIXTURE_FILE}")
set_tests_properties(ply_open3d_read PROPERTIES FIXTURES_REQUIRED ply_open3d_file TIMEOUT 300)

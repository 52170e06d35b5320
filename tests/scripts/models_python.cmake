# The Python side of models/ (network, quantiser, exporter, ONNX import, bit-exact numpy int8
# forward): its unittest suite, with Debian's python3-torch, python3-onnx, python3-opencv and numpy
# (scripts/install-deps.sh test). EDGEFUSION points the ONNX import test at this build's binary,
# which it uses to render its calibration frames. Included by tests/CMakeLists.txt, native builds only.
# Not in the sanitizer builds: the suite is Python, and the binary's part in it (rendering frames)
# is covered there by the C++ tests.
if(EF_SANITIZE)
  return()
endif()
add_test(NAME models_python
         COMMAND /usr/bin/python3 -m unittest discover -s models/tests -t models
         WORKING_DIRECTORY "${PROJECT_SOURCE_DIR}")
set_tests_properties(models_python PROPERTIES TIMEOUT 600
                     ENVIRONMENT "EDGEFUSION=$<TARGET_FILE:edgefusion>;PYTHONDONTWRITEBYTECODE=1")

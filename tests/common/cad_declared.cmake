# What CAD files declare about themselves, checked before import (cad_declared.c).
pm_add_test(test_cad_declared LABELS unit backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_cad_declared.c)

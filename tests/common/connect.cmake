# The connection layer (connect.c).
pm_add_test(test_connect LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_connect.c)
# Edge removal of flat tets (tet_flip.c).
pm_add_test(test_tet_flip LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_tet_flip.c)

# Nodes of gmsh's own mesh of every shared CAD model, connected by pm_connect: one ctest entry
# per model (a crash of gmsh's mesher on one model stays that model's failure).
add_executable(test_connect_cad ${CMAKE_CURRENT_LIST_DIR}/test_connect_cad.c)
target_compile_options(test_connect_cad PRIVATE ${PM_WARNINGS})
target_include_directories(test_connect_cad PRIVATE ${CMAKE_SOURCE_DIR}/tests)
target_include_directories(test_connect_cad SYSTEM PRIVATE ${GMSH_INCLUDE_DIR})
target_compile_definitions(test_connect_cad PRIVATE PM_CAD_DIR="${PM_CAD_DIR}")
target_link_libraries(test_connect_cad PRIVATE packmesh ${CMOCKA_LIBRARIES} m)
set(PM_CONNECT_CAD_FAST planar_step.brep crack.brep synth_box_hole.brep synth_box_hole.step
  synth_bspline_patch.brep synth_cone.brep synth_sphere.brep synth_torus.brep synth_torus.step
  slender_face.brep cyl_loop_seam.brep bspline_sphere.brep screw.step t20_component8.step
  cube_fillet.stp table.brep base_interface.step wrench.stp featuretype.step
  cylinder_head.stp box_sides.step bottle.brep bearing.iges fusee.stp)
set(PM_CONNECT_CAD_LONG engine_block.stp solid56.step)
foreach(f ${PM_CONNECT_CAD_FAST})
  add_test(NAME test_connect_cad_${f} COMMAND test_connect_cad ${PM_CAD_DIR}/${f})
  set_tests_properties(test_connect_cad_${f} PROPERTIES LABELS "backend" TIMEOUT 300
    ENVIRONMENT "${PM_TEST_ENV}")
endforeach()
foreach(f ${PM_CONNECT_CAD_LONG})
  add_test(NAME test_connect_cad_${f} COMMAND test_connect_cad ${PM_CAD_DIR}/${f})
  set_tests_properties(test_connect_cad_${f} PROPERTIES LABELS "backend;long" TIMEOUT 1200
    ENVIRONMENT "${PM_TEST_ENV}")
endforeach()
# A node set on which TetGen 1.5 leaves inner tets without a region: without the flood-fill
# retagging of the volume step, those tets were dropped and left holes. (Size 0.0667 did this
# until two of the bottle's boundary curves were taken by projection at load, which moved its
# boundary triangles; at 0.066 TetGen's refinement now leaves 4.)
add_test(NAME test_connect_cad_retag COMMAND test_connect_cad ${PM_CAD_DIR}/bottle.brep 0.066 3)
set_tests_properties(test_connect_cad_retag PROPERTIES LABELS "backend" TIMEOUT 300
  ENVIRONMENT "${PM_TEST_ENV}")
# A node set on which TetGen 1.5's boundary recovery, taking the facets in the given order, loses
# a triangle of the bottle's neck band (recovered with the facets in reverse order).
add_test(NAME test_connect_cad_facet_order COMMAND test_connect_cad ${PM_CAD_DIR}/bottle.brep 0.065)
set_tests_properties(test_connect_cad_facet_order PROPERTIES LABELS "backend" TIMEOUT 300
  ENVIRONMENT "${PM_TEST_ENV}")

# A face whose pcurve disagrees with its 3D curve (fusee.stp face 85): step 1b of connect.c.
pm_add_test(test_connect_crossed LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_connect_crossed.c TIMEOUT 120)

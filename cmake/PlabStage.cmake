# plab_add_stage(SOURCES file... [CUDA_SOURCES file...] [TEST_MAX_N n] [GPU] [EXACT] [FLOAT])
#
# Called from each stage folder's CMakeLists.txt (stages/NN-name or solutions/NN-name). Adds:
#   plab_stage_NN_IMPL   a library with the stage's step() (IMPL: student or solution)
#   plab-run-NN-IMPL     the program `plab run --stage NN --impl IMPL` starts
# and records the stage so that tests/ adds its tests. TEST_MAX_N: the largest scene its golden
# tests run (stage 01 is O(N^3) per step by design). GPU: a CUDA stage (its sources define
# plab::make_stepper(); PLAB_GPU_STAGE is set for it and its users), skipped without nvcc.
# CUDA_SOURCES: a CPU stage's GPU version, compiled when nvcc is found (PLAB_HYBRID_STAGE is then
# set: its make_stepper() takes the GPU when there is one). EXACT: the exact event-driven
# reference (stage 07), not model.md's stepped model: its sources define plab::make_stepper()
# (PLAB_EXACT_STAGE is set), it has its own tests and golden files. FLOAT: the stage also defines
# plab::step_float() (PLAB_FLOAT_STAGE is set), the float variant `plab accuracy` measures.
function(plab_add_stage)
  cmake_parse_arguments(S "GPU;EXACT;FLOAT" "TEST_MAX_N" "SOURCES;CUDA_SOURCES" ${ARGN})
  get_filename_component(folder ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  get_filename_component(tree ${CMAKE_CURRENT_SOURCE_DIR} DIRECTORY)
  get_filename_component(tree ${tree} NAME)
  string(SUBSTRING ${folder} 0 2 id)
  string(SUBSTRING ${folder} 3 -1 name)
  if(tree STREQUAL "solutions")
    set(impl solution)
  else()
    set(impl student)
  endif()
  if(S_GPU AND NOT PLAB_HAVE_CUDA)
    message(STATUS "stage ${id} (${impl}): skipped, no CUDA compiler")
    return()
  endif()
  if(NOT S_TEST_MAX_N)
    set(S_TEST_MAX_N 1000000000)
  endif()

  set(lib plab_stage_${id}_${impl})
  add_library(${lib} STATIC ${S_SOURCES})
  target_link_libraries(${lib} PUBLIC plab::kit)
  target_compile_definitions(${lib} PRIVATE PLAB_STAGE_ID="${id}")
  if(S_FLOAT)
    target_compile_definitions(${lib} PUBLIC PLAB_FLOAT_STAGE=1)
  endif()
  set(kind cpu)
  if(S_EXACT)
    set(kind exact)
    target_compile_definitions(${lib} PUBLIC PLAB_EXACT_STAGE=1)
  elseif(S_GPU)
    set(kind gpu)
    target_link_libraries(${lib} PUBLIC plab::cuda)
    target_compile_definitions(${lib} PUBLIC PLAB_GPU_STAGE=1)
  elseif(S_CUDA_SOURCES AND PLAB_HAVE_CUDA)
    set(kind hybrid)
    target_sources(${lib} PRIVATE ${S_CUDA_SOURCES})
    target_link_libraries(${lib} PUBLIC plab::cuda)
    target_compile_definitions(${lib} PUBLIC PLAB_HYBRID_STAGE=1)
  endif()

  set(program plab-run-${id}-${impl})
  add_executable(${program} ${PROJECT_SOURCE_DIR}/kit/runner/main.cpp)
  target_link_libraries(${program} PRIVATE ${lib} CLI11::CLI11 nlohmann_json::nlohmann_json)
  target_compile_definitions(${program} PRIVATE PLAB_STAGE_ID="${id}" PLAB_IMPL="${impl}")

  set_property(GLOBAL APPEND PROPERTY PLAB_STAGES "${id}:${name}:${impl}:${S_TEST_MAX_N}:${kind}")
endfunction()

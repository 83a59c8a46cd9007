# lancer - see README.md. `make run` renders the default scene, `make test` runs every test.
#
# Three build trees share these rules: build/ (optimised, what `make run`
# uses), build/san/ (AddressSanitizer + UBSan, what `make test` uses) and
# build/tsan/ (SAN=thread, ThreadSanitizer, for `make test-threads`). The tree
# is chosen by BUILD and SAN; `make test` calls this Makefile again with each.

BUILD ?= build
SAN   ?= 0

CC      ?= cc
WARN    := -Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes -Wmissing-prototypes \
           -Wold-style-definition -Wcast-qual -Wwrite-strings -Wundef -Wvla -Wformat=2 \
           -Wpointer-arith -Wnull-dereference -Wimplicit-fallthrough
# -ffp-contract=off: no silent FMA contraction, so the float bits a routine
# computes do not depend on the target's instruction set (the exact judge
# reasons about those bits). Never -ffast-math here.
BASEFLAGS := -std=c99 $(WARN) -ffp-contract=off -pthread
ifeq ($(SAN),1)
OPTFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
SANLINK  := -fsanitize=address,undefined
else ifeq ($(SAN),thread)
OPTFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=thread
SANLINK  := -fsanitize=thread
else
# -O3, not -O2: the BVH traversal then runs 10-20% faster (make bench,
# bunny00, alternating), with the same float bits (no -ffast-math).
OPTFLAGS := -O3 -g
SANLINK  :=
endif
ifeq ($(WERROR),1)
BASEFLAGS += -Werror
endif

PKGS     := OpenEXR libpng
# -isystem: OpenEXRCore's headers use C11 anonymous unions, which -Wpedantic
# would report in every file that includes them.
CPPFLAGS += -Iinclude -D_POSIX_C_SOURCE=200809L \
            $(patsubst -I%,-isystem %,$(shell pkg-config --cflags $(PKGS) 2>/dev/null))
CFLAGS   ?=
ALLCFLAGS = $(BASEFLAGS) $(OPTFLAGS) $(CFLAGS)
LDLIBS   += -Wl,--as-needed $(shell pkg-config --libs $(PKGS) 2>/dev/null) -lm
LDFLAGS  += -pthread $(SANLINK)

# The library (src/*.c) and the command line, its client (src/cli/*.c).
LIB_SRC  := $(wildcard src/*.c)
LIB_OBJ  := $(LIB_SRC:src/%.c=$(BUILD)/obj/%.o)
CLI_SRC  := $(wildcard src/cli/*.c)
CLI_OBJ  := $(CLI_SRC:src/cli/%.c=$(BUILD)/obj/cli/%.o)
BENCH_OBJ := $(BUILD)/obj/cli/bench.o
# On x86-64 the BVH traversal is built once more for AVX2, and picked at
# run time when the processor has it (src/bvh_traverse.c).
ifeq ($(shell uname -m),x86_64)
LIB_OBJ  += $(BUILD)/obj/bvh_traverse_avx2.o
endif
TEST_SRC := $(wildcard tests/test_*.c)
TEST_BIN := $(TEST_SRC:tests/%.c=$(BUILD)/%)

.PHONY: all run test tests deps-run deps-test clean exact exact-judge stress cgal-data bench install uninstall \
        fuzz fuzz-build fuzzers frontier test-cluster test-oom test-threads
.DEFAULT_GOAL := all

all: $(BUILD)/lancer

$(BUILD)/obj/%.o: src/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/obj/cli/%.o: src/cli/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/obj/tests/%.o: tests/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/liblancer.a: $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BUILD)/lancer: $(CLI_OBJ) $(BUILD)/liblancer.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/test_%: $(BUILD)/obj/tests/test_%.o $(BUILD)/liblancer.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -lcmocka -o $@

# test_bench tests the benchmarks' rays, which live beside the command line.
$(BUILD)/test_bench: $(BUILD)/obj/tests/test_bench.o $(BENCH_OBJ) $(BUILD)/liblancer.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -lcmocka -o $@

$(BUILD)/obj/bvh_traverse_avx2.o: src/bvh_traverse.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -DLANCER_AVX2_VARIANT -mavx2 -mbmi $(ALLCFLAGS) -MMD -MP -c $< -o $@

# The BVH and the four-lane triangle test without SIMD (scalar), and the
# traversal with SSE only (no AVX2), run through the same tests as what
# the processor picks.
$(BUILD)/obj/%_scalar.o: src/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -DLANCER_NO_SIMD $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/obj/%_sse.o: src/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -DLANCER_NO_AVX2 $(ALLCFLAGS) -MMD -MP -c $< -o $@

BVH_OBJ := $(BUILD)/obj/bvh.o $(BUILD)/obj/bvh_traverse.o $(BUILD)/obj/bvh_traverse_avx2.o

$(BUILD)/test_bvh_scalar: $(BUILD)/obj/tests/test_bvh.o $(BUILD)/obj/bvh_scalar.o $(BUILD)/obj/bvh_traverse_scalar.o \
                          $(filter-out $(BVH_OBJ),$(LIB_OBJ))
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -lcmocka -o $@

$(BUILD)/test_bvh_sse: $(BUILD)/obj/tests/test_bvh.o $(BUILD)/obj/bvh_traverse_sse.o \
                       $(filter-out $(BUILD)/obj/bvh_traverse.o $(BUILD)/obj/bvh_traverse_avx2.o,$(LIB_OBJ))
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -lcmocka -o $@

# test_prim once more with -mavx2, for the AVX2 forms in src/tri4.h that
# the traversal inlines (it skips itself on a processor without AVX2).
ifeq ($(shell uname -m),x86_64)
TEST_AVX2 := $(BUILD)/test_prim_avx2
endif
$(BUILD)/obj/tests/test_prim_avx2.o: tests/test_prim.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -mavx2 -mbmi $(ALLCFLAGS) -MMD -MP -c $< -o $@

# The fuzz harnesses (tests/fuzz), one per reader; the four mesh readers
# share one source, built once per format. In any tree a harness links with
# replay.c into build/.../replay_NAME, which runs files through it once (make
# test replays tests/fuzz/regressions/ so); in the clang tree build/fuzz it
# links with libFuzzer into build/fuzz/fuzz_NAME.
FUZZ_NAMES := scene off obj ply stl exr rays
FUZZ_MESH  := off obj ply stl
REPLAY_BIN := $(FUZZ_NAMES:%=$(BUILD)/replay_%)
FUZZ_BIN   := $(FUZZ_NAMES:%=$(BUILD)/fuzz_%)
FUZZ_SECONDS ?= 60

$(BUILD)/obj/fuzz/%.o: tests/fuzz/%.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(FUZZ_MESH:%=$(BUILD)/obj/fuzz/fuzz_%.o): $(BUILD)/obj/fuzz/fuzz_%.o: tests/fuzz/fuzz_mesh.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -DFUZZ_FORMAT=MESH_$(shell echo $* | tr a-z A-Z) $(ALLCFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/replay_%: $(BUILD)/obj/fuzz/fuzz_%.o $(BUILD)/obj/fuzz/replay.o $(BUILD)/liblancer.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/fuzz_%: $(BUILD)/obj/fuzz/fuzz_%.o $(BUILD)/liblancer.a
	$(CC) $(LDFLAGS) -fsanitize=fuzzer $^ $(LDLIBS) -o $@

fuzzers: $(FUZZ_BIN)

tests: $(BUILD)/lancer $(TEST_BIN) $(BUILD)/test_bvh_scalar $(BUILD)/test_bvh_sse $(TEST_AVX2) $(REPLAY_BIN)

# The exact judge (tests/exact): C++17 + CGAL, linked against the release
# library build/liblancer.a, so it measures the very object code lancer runs
# (built with the flags above). Only exact.cpp and mesh.cpp include CGAL, which
# compiles slowly; -frounding-math is what CGAL's interval filters need.
EXACT_DIR      := build/exact
EXACT_SRC      := $(wildcard tests/exact/*.cpp)
EXACT_OBJ      := $(EXACT_SRC:tests/exact/%.cpp=$(EXACT_DIR)/%.o)
EXACT_CXXFLAGS := -std=c++17 -O2 -ffp-contract=off -frounding-math -Wall -Wextra -Wno-maybe-uninitialized
EXACT_RAYS     ?= 1000000
STRESS_RAYS    ?= 100000000
# rays per closed mesh and placement of test_pntri's crack test in `make
# stress`: 4 meshes x 5 placements x 50000 = 10^6
STRESS_PN_RAYS ?= 50000
# random parity scenes in `make stress` (scripts/parity-random.sh)
STRESS_SCENES  ?= 1000

$(EXACT_DIR)/%.o: tests/exact/%.cpp
	@mkdir -p $(@D)
	$(CXX) -Iinclude $(EXACT_CXXFLAGS) -MMD -MP -c $< -o $@

$(EXACT_DIR)/judge: $(EXACT_OBJ) build/liblancer.a
	$(CXX) $(EXACT_OBJ) build/liblancer.a -lmpfr -lgmpxx -lgmp -pthread -o $@

# The quick start, step one: dependencies, build, render the default scene.
run: deps-run
	$(MAKE) all
	@mkdir -p out
	$(BUILD)/lancer render scenes/default.scn -o out/default.exr --png out/default.png

# The quick start, step two: every test, on the sanitized build with -Werror,
# then the exact judge (EXACT_RAYS rays per case) on the release library.
test: deps-test
	$(MAKE) BUILD=build/san SAN=1 WERROR=1 tests
	$(MAKE) exact-judge
	EXACT_RAYS=$(EXACT_RAYS) sh scripts/run-tests.sh build/san $(EXACT_DIR)/judge
	$(MAKE) test-cluster
	$(MAKE) test-oom
	$(MAKE) test-threads

# Data races: lancer built with ThreadSanitizer (build/tsan), on renders,
# builds, writes and signals that run threads side by side.
test-threads:
	$(MAKE) BUILD=build/tsan SAN=thread WERROR=1 build/tsan/lancer
	sh tests/threads.sh build/tsan/lancer

# Out of memory at each allocation of the commands that write files, on the
# release build (a preloaded allocator, which sanitizers would displace).
test-oom:
	$(MAKE) all
	sh tests/oom.sh $(BUILD)/lancer

# lancer on a one-node Slurm cluster and GNU parallel, started and stopped
# by the test (root only; skipped with a message otherwise), on the
# release build: the renders must be large enough to stop midway.
test-cluster: deps-test
	$(MAKE) all
	bash tests/cluster.sh $(BUILD)/lancer

# Fuzzing: each harness for FUZZ_SECONDS (default 60) from the seeds the
# tests and scenes give, the corpus kept in build/fuzz-corpus between runs.
# The fuzzers are built with clang (libFuzzer, ASan, UBSan) in build/fuzz.
fuzz: deps-test fuzz-build
	$(MAKE) BUILD=build/san SAN=1 WERROR=1 tests
	sh scripts/fuzz.sh build/fuzz build/san $(FUZZ_SECONDS)

fuzz-build:
	$(MAKE) BUILD=build/fuzz SAN=1 WERROR=1 CC=clang CFLAGS=-fsanitize=fuzzer-no-link fuzzers

# The exact judge alone: `make exact`, or `make stress` (STRESS_RAYS per case,
# then the PN crack test at 10^6 rays, then STRESS_SCENES random parity
# scenes; hours). Both build build/liblancer.a with the release flags first.
exact: deps-test exact-judge
	$(EXACT_DIR)/judge $(EXACT_RAYS)

stress: deps-test exact-judge
	$(EXACT_DIR)/judge $(STRESS_RAYS)
	$(MAKE) BUILD=build/san SAN=1 WERROR=1 build/san/test_pntri
	LANCER_PN_CRACK_RAYS=$(STRESS_PN_RAYS) build/san/test_pntri
	$(MAKE) all
	sh scripts/parity-random.sh $(BUILD)/lancer $(STRESS_SCENES)

# Benchmarks (not tests): the routines' speed, lancer against Embree on ray
# files of six CGAL meshes, the bunny frame and the parity scenes against
# POV-Ray, and PN surfaces' time against error; then one table of the
# targets against the measured ratios (build/bench/table.md).
$(BUILD)/prim_bench: tests/bench/prim_bench.c $(BUILD)/liblancer.a
	$(CC) $(CPPFLAGS) -Isrc/cli $(ALLCFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/pn_tess: tests/bench/pn_tess.c $(BUILD)/liblancer.a
	$(CC) $(CPPFLAGS) $(ALLCFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/embree_bench: tests/bench/embree_bench.c $(BENCH_OBJ) $(BUILD)/liblancer.a
	$(CC) $(CPPFLAGS) -Isrc/cli $(ALLCFLAGS) $^ -lembree3 $(LDLIBS) -o $@

bench:
	sh scripts/deps.sh bench
	sh scripts/cgal-data.sh build/cgal-data
	$(MAKE) all $(BUILD)/prim_bench $(BUILD)/embree_bench $(BUILD)/pn_tess
	mkdir -p build/bench
	: >build/bench/results.tsv
	sh scripts/bench.sh build/bench/results.tsv
	@echo; echo "## The bunny mirror frame against POV-Ray"; echo
	sh scripts/bench-frame.sh $(BUILD)/lancer 9 build/bench/results.tsv
	@echo; echo "## The parity scenes against POV-Ray"; echo
	sh scripts/bench-pov.sh $(BUILD)/lancer 5 2 build/bench/results.tsv
	@echo; echo "## PN surfaces: time against error"; echo
	sh scripts/bench-pn.sh $(BUILD)/lancer $(BUILD)/pn_tess build/bench/results.tsv
	@echo; echo "## Targets"; echo
	@sh scripts/bench-table.sh build/bench/results.tsv | tee build/bench/table.md

# Time against error: the render knobs swept on six scenes (the bunny's mesh
# from cgal-data), against POV-Ray references; writes build/frontier/frontier.csv
# and the plots docs/frontier/*.png (deps.sh bench brings POV-Ray and gnuplot).
frontier:
	sh scripts/deps.sh bench
	$(MAKE) cgal-data all
	sh scripts/frontier.sh $(BUILD)/lancer

exact-judge: cgal-data
	$(MAKE) -j2 BUILD=build SAN=0 $(EXACT_DIR)/judge

cgal-data:
	sh scripts/cgal-data.sh build/cgal-data

# Installs the binary and the manual page (docs/lancer.1) under PREFIX;
# DESTDIR stages them for a package.
PREFIX ?= /usr/local
BINDIR := $(PREFIX)/bin
MAN1DIR := $(PREFIX)/share/man/man1

install: all
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(MAN1DIR)
	install -m 755 $(BUILD)/lancer $(DESTDIR)$(BINDIR)/lancer
	install -m 644 docs/lancer.1 $(DESTDIR)$(MAN1DIR)/lancer.1

uninstall:
	rm -f $(DESTDIR)$(BINDIR)/lancer $(DESTDIR)$(MAN1DIR)/lancer.1

deps-run:
	sh scripts/deps.sh run

deps-test:
	sh scripts/deps.sh test

clean:
	rm -rf build

-include $(wildcard $(BUILD)/obj/*.d $(BUILD)/obj/cli/*.d $(BUILD)/obj/tests/*.d $(BUILD)/obj/fuzz/*.d $(EXACT_DIR)/*.d)

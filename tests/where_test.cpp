/// \file where_test.cpp
/// \brief plab/mpi/where.hpp: the line a watcher prints for the ranks of a stalled run.
#include <gtest/gtest.h>

#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "plab/mpi/where.hpp"

namespace {

/// Writes `line` NUL-padded as the driver's mapping leaves it.
void write_rank(const std::string& dir, int rank, const std::string& line) {
  std::string page(plab::dist::kWhereBytes, '\0');
  page.replace(0, line.size(), line);
  std::ofstream(plab::dist::where_file(dir, rank), std::ios::binary) << page;
}

class Where : public testing::Test {
 protected:
  void SetUp() override {  // a folder of its own: CTest runs these tests side by side
    std::string templ = (std::filesystem::temp_directory_path() / "plab-where-test-XXXXXX").string();
    ASSERT_NE(mkdtemp(templ.data()), nullptr);
    dir_ = templ;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string dir_;
};

TEST_F(Where, NamesEachRanksCallAndSaysWhenTheyDiffer) {
  write_rank(dir_, 0, "in MPI_Alltoall (step 3)");
  write_rank(dir_, 1, "in MPI_Waitall (step 3)");
  EXPECT_EQ(plab::dist::where_ranks_are(dir_, 2),
            "rank 0: in MPI_Alltoall (step 3); rank 1: in MPI_Waitall (step 3) (not all in the "
            "same place: the ranks ahead skipped a call, or left a loop, that the others wait in)");
}

TEST_F(Where, RanksInTheSameCallAreNotSaidApart) {
  write_rank(dir_, 0, "in MPI_Recv (step 1)");
  write_rank(dir_, 1, "in MPI_Recv (step 1)");
  EXPECT_EQ(plab::dist::where_ranks_are(dir_, 2),
            "rank 0: in MPI_Recv (step 1); rank 1: in MPI_Recv (step 1)");
}

TEST_F(Where, NothingWrittenSaysNothing) {
  EXPECT_EQ(plab::dist::where_ranks_are(dir_, 3), "");
  write_rank(dir_, 1, "between steps (step 2)");
  EXPECT_EQ(plab::dist::where_ranks_are(dir_, 2),
            "rank 0: unknown; rank 1: between steps (step 2) (not all in the same place: the "
            "ranks ahead skipped a call, or left a loop, that the others wait in)");
}

}  // namespace

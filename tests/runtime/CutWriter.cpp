// The child process of Refinement.CutsAreIdenticalAcrossProcesses (TestRefinement.cpp): writes
// the serialized cuts of the tolerance cameras on the MOLA test dataset to stdout.
#include <cstdio>

#include "RefinementCuts.h"
#include "TestData.h"

int main() {
  const std::string cuts = pbdam::test::serializeToleranceCuts(
      pbdam::test::testDatasetDir("mola"), pbdam::test::dataDir() / "mars/megt90n000cb.lbl");
  if (cuts.empty()) {
    std::fprintf(stderr, "cut writer: cannot read the MOLA test dataset or DEM\n");
    return 1;
  }
  return std::fwrite(cuts.data(), 1, cuts.size(), stdout) == cuts.size() ? 0 : 1;
}

// The coordinator's memory (what a coupled step starts from) is saved into and restored from a
// state through one table of its fields: these tests hold because the table, not three lists
// written out by hand, decides what is saved, read and checked.
#include "smooth_solver/coupling/coupling_memory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace cosim::smooth {
namespace {

constexpr int kPoints = 2;

// The repeated doubles of state.proto's CoordinatorMemory, found by reflection (not from the table
// under test).
std::vector<const google::protobuf::FieldDescriptor*> SavedVectors() {
  const google::protobuf::Descriptor* d = state::CoordinatorMemory::descriptor();
  std::vector<const google::protobuf::FieldDescriptor*> out;
  for (int f = 0; f < d->field_count(); ++f) {
    const google::protobuf::FieldDescriptor* field = d->field(f);
    if (field->is_repeated() && field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) {
      out.push_back(field);
    }
  }
  return out;
}

// A memory whose every value differs from every other (and from a fresh memory's zeros).
CouplingMemory Distinct() {
  CouplingMemory m(kPoints);
  state::CoordinatorMemory saved;
  m.Write(&saved);
  const google::protobuf::Reflection* r = saved.GetReflection();
  double next = 1.0;
  for (const google::protobuf::FieldDescriptor* field : SavedVectors()) {
    for (int i = 0; i < r->FieldSize(saved, field); ++i) r->SetRepeatedDouble(&saved, field, i, next++);
  }
  saved.set_accepted_steps(7);
  saved.set_accepted_h(1e-3);
  saved.set_previous_accepted_h(2e-3);
  saved.set_offset_known(true);
  saved.set_was_contact(1, true);
  EXPECT_EQ(m.Read(saved), "");
  return m;
}

TEST(CouplingMemory, WhatIsSavedIsWhatIsRestored) {
  const CouplingMemory m = Distinct();
  state::CoordinatorMemory first, second;
  m.Write(&first);
  CouplingMemory copy(kPoints);
  ASSERT_EQ(copy.Read(first), "");
  copy.Write(&second);
  EXPECT_EQ(first.SerializeAsString(), second.SerializeAsString());
  EXPECT_EQ(copy.accepted_steps, 7);
  EXPECT_TRUE(copy.offset_known);
  EXPECT_TRUE(copy.was_contact[1]);
  EXPECT_FALSE(copy.was_contact[0]);
  // S of point 1 is the second block of nine, row-major.
  EXPECT_EQ(copy.Sensitivity(1)(0, 1), copy.sensitivity(10));
}

TEST(CouplingMemory, EveryVectorOfTheSavedMessageIsReadAndChecked) {
  // Every repeated double of state.proto's CoordinatorMemory (not only those someone listed):
  // a saved vector one value short, or with a NaN, is refused naming that field, and the memory
  // is left as it was. A field added to the message but not to the table fails here.
  const CouplingMemory m = Distinct();
  state::CoordinatorMemory good;
  m.Write(&good);
  const google::protobuf::Reflection* r = good.GetReflection();
  int vectors = 0;
  for (const google::protobuf::FieldDescriptor* field : SavedVectors()) {
    ++vectors;
    const int size = r->FieldSize(good, field);
    ASSERT_GT(size, 0) << field->name() << " was not saved";
    state::CoordinatorMemory shorter = good;
    r->RemoveLast(&shorter, field);
    CouplingMemory target(kPoints);
    EXPECT_EQ(target.Read(shorter), "its coordinator's " + field->name() + " has " + std::to_string(size - 1) +
                                        " values, not " + std::to_string(size));
    state::CoordinatorMemory nan = good;
    r->SetRepeatedDouble(&nan, field, size - 1, std::numeric_limits<double>::quiet_NaN());
    const std::string refused = target.Read(nan);
    EXPECT_NE(refused.find("coordinator's " + field->name() + "[" + std::to_string(size - 1) + "]"), std::string::npos)
        << refused;
    state::CoordinatorMemory untouched;
    target.Write(&untouched);
    EXPECT_EQ(untouched.SerializeAsString(),
              [] {
                state::CoordinatorMemory fresh;
                CouplingMemory(kPoints).Write(&fresh);
                return fresh.SerializeAsString();
              }())
        << "a refused memory changed " << field->name();
  }
  EXPECT_EQ(vectors, 11);
}

TEST(CouplingMemory, AnotherScenesMemoryOrANegativeStepIsRefused) {
  const CouplingMemory m = Distinct();
  state::CoordinatorMemory saved;
  m.Write(&saved);
  CouplingMemory three(3);
  EXPECT_EQ(three.Read(saved), "its coordinator's memory is of 2 interface points, not 3");
  state::CoordinatorMemory negative = saved;
  negative.set_accepted_h(-1e-3);
  CouplingMemory target(kPoints);
  EXPECT_NE(target.Read(negative).find("accepted_h"), std::string::npos);
  state::CoordinatorMemory contacts = saved;
  contacts.mutable_was_contact()->RemoveLast();
  EXPECT_EQ(target.Read(contacts), "its coordinator's was_contact has 1 values, not 2");
}

}  // namespace
}  // namespace cosim::smooth

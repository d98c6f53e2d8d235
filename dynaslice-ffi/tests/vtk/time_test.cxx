// The time rule through the VTK adapter (include/dynaslice_vtk.h), built and run by
// scripts/ci-ffi.sh.
//
// Usage: vtk_time_test MODEL.dsm
//
// vtkDynaSliceFunction answers on both edges of the model's time range and never extrapolates:
// a time outside it (or NaN) is reported once through vtkErrorMacro (caught here as VTK's
// ErrorEvent) and every value is NaN, whether the time came before or after the model and
// however many points (and threads, through vtkSampleFunction) evaluate it.
#include "dynaslice_vtk.h"

#include <vtkCommand.h>
#include <vtkDoubleArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSampleFunction.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

namespace {

int checks = 0, failures = 0;

void check(bool ok, const char* what, int line)
{
  checks++;
  if (!ok)
  {
    failures++;
    std::fprintf(stderr, "time_test.cxx:%d: check failed: %s\n", line, what);
  }
}
#define CHECK(cond) check((cond), #cond, __LINE__)

// Counts the ErrorEvents of the objects it observes and keeps the last message.
class ErrorCounter : public vtkCommand
{
public:
  static ErrorCounter* New() { return new ErrorCounter; }
  void Execute(vtkObject*, unsigned long, void* data) override
  {
    this->Count++;
    this->Last = data ? static_cast<const char*>(data) : "";
  }
  int Count = 0;
  std::string Last;
};

// Samples `f` on a 12³ grid over the model's bounds (vtkSampleFunction, VTK's SMP threads);
// returns how many samples are NaN (-1 when the sampler produced nothing).
vtkIdType SampleNaNs(vtkDynaSliceFunction* f)
{
  float lo[3], hi[3];
  ds_bounds(f->GetModel(), lo, hi);
  vtkNew<vtkSampleFunction> sampler;
  sampler->SetImplicitFunction(f);
  sampler->SetModelBounds(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]);
  sampler->SetSampleDimensions(12, 12, 12);
  sampler->ComputeNormalsOff();
  sampler->Update();
  vtkDataArray* values = sampler->GetOutput()->GetPointData()->GetScalars();
  if (!values || values->GetNumberOfTuples() != 12 * 12 * 12)
  {
    return -1;
  }
  vtkIdType nans = 0;
  for (vtkIdType i = 0; i < values->GetNumberOfTuples(); i++)
  {
    nans += std::isnan(values->GetTuple1(i)) ? 1 : 0;
  }
  return nans;
}

// Every form of evaluation at one point: value, gradient and the vtkDataArray (batch) form.
// Returns true when all are finite, false when all are NaN; a mix fails a check.
bool Evaluate(vtkDynaSliceFunction* f, double x[3])
{
  double g[3];
  const double v = f->EvaluateFunction(x);
  f->EvaluateGradient(x, g);
  vtkNew<vtkDoubleArray> in, out;
  in->SetNumberOfComponents(3);
  in->InsertNextTuple(x);
  in->InsertNextTuple(x);
  f->EvaluateFunction(in, out);
  const bool finite = std::isfinite(v) && std::isfinite(g[0]) && std::isfinite(g[1]) &&
    std::isfinite(g[2]) && std::isfinite(out->GetTuple1(0)) && std::isfinite(out->GetTuple1(1));
  const bool nan = std::isnan(v) && std::isnan(g[0]) && std::isnan(g[1]) && std::isnan(g[2]) &&
    std::isnan(out->GetTuple1(0)) && std::isnan(out->GetTuple1(1));
  CHECK(finite || nan);
  return finite;
}

} // namespace

int main(int argc, char** argv)
{
  if (argc != 2)
  {
    std::fprintf(stderr, "usage: %s MODEL.dsm\n", argv[0]);
    return 2;
  }
  vtkNew<vtkDynaSliceFunction> f;
  vtkNew<ErrorCounter> errors;
  f->AddObserver(vtkCommand::ErrorEvent, errors);
  if (f->LoadModel(argv[1]) != DS_OK)
  {
    std::fprintf(stderr, "cannot open %s: %s\n", argv[1], ds_last_error_message());
    return 1;
  }
  float t0, t1, lo[3], hi[3];
  CHECK(ds_time_range(f->GetModel(), &t0, &t1) == DS_OK && t0 < t1);
  ds_bounds(f->GetModel(), lo, hi);
  double centre[3] = { (lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0 };
  const double span = static_cast<double>(t1) - t0;

  // Both edges and the middle are answered, without an error.
  for (const double t : { static_cast<double>(t0), static_cast<double>(t1), t0 + span / 2 })
  {
    f->SetTime(t);
    CHECK(f->CheckTime() == DS_OK);
    CHECK(Evaluate(f, centre));
  }
  CHECK(SampleNaNs(f) == 0);
  CHECK(errors->Count == 0);

  // Outside the range, and NaN: SetTime reports it at once, evaluation gives NaN and reports
  // nothing more (one message per time), the next bad time is reported again.
  int reported = 0;
  for (const double t : { t1 + span / 2, t0 - span / 100, 1e30, static_cast<double>(NAN) })
  {
    f->SetTime(t);
    CHECK(errors->Count == ++reported);
    CHECK(errors->Last.find("is outside the model's time range") != std::string::npos);
    CHECK(f->CheckTime() == DS_E_TIME_OUT_OF_RANGE);
    CHECK(!Evaluate(f, centre));
    CHECK(SampleNaNs(f) == 12 * 12 * 12);
    CHECK(errors->Count == reported);
  }
  f->SetTime(t1);
  CHECK(Evaluate(f, centre) && errors->Count == reported);

  // A time set before the model is reported by the first evaluation, once, even from
  // vtkSampleFunction's threads.
  vtkNew<vtkDynaSliceFunction> late;
  vtkNew<ErrorCounter> late_errors;
  late->AddObserver(vtkCommand::ErrorEvent, late_errors);
  late->SetTime(t1 + span);
  CHECK(late->CheckTime() == DS_E_NULL_POINTER);
  CHECK(late_errors->Count == 0);
  late->SetSharedModel(f->GetModel());
  CHECK(SampleNaNs(late) == 12 * 12 * 12);
  CHECK(!Evaluate(late, centre));
  CHECK(late_errors->Count == 1);
  CHECK(late_errors->Last.find("ds_eval") != std::string::npos);
  CHECK(late_errors->Last.find("is outside the model's time range") != std::string::npos);
  late->SetTime(t0);
  CHECK(Evaluate(late, centre) && late_errors->Count == 1);
  late->SetSharedModel(nullptr);

  std::printf("VTK time test: %d passed, %d failed\n", checks - failures, failures);
  return failures == 0 ? 0 : 1;
}

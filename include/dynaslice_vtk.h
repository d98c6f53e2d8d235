/*
 * dynaslice_vtk.h: a header-only vtkImplicitFunction over one class of a DynaSlice model at a
 * chosen time, for VTK, ParaView and 3D Slicer hosts (docs/c-api.md, "VTK").
 *
 *   vtkNew<vtkDynaSliceFunction> f;
 *   if (f->LoadModel("heart.dsm") != DS_OK) { ... ds_last_error_message() ... }
 *   f->SetClass(2);       // 1..K
 *   f->SetTime(0.35);     // world time units
 *   sampler->SetImplicitFunction(f);   // e.g. vtkSampleFunction, then vtkFlyingEdges3D
 *
 * EvaluateFunction returns f^k in world units (negative inside), EvaluateGradient the exact
 * ∇ₓf^k, and the vtkDataArray form evaluates many points through ds_eval_batch. Evaluation does
 * not modify the object's settings, so VTK's SMP filters may call it from many threads at once.
 * Without a model, or with a class outside 1..K, every value is NaN.
 *
 * The time must lie in the model's time range (ds_time_range), as for every DynaSlice front end:
 * the function never extrapolates in time. SetTime with a model in place reports a time outside
 * it through vtkErrorMacro at once; evaluating at such a time (or one set before the model)
 * gives NaN everywhere and reports the library's message through vtkErrorMacro, once per time
 * and model. CheckTime() returns DS_OK or DS_E_TIME_OUT_OF_RANGE for a host to stop before
 * sampling.
 */
#ifndef DYNASLICE_VTK_H
#define DYNASLICE_VTK_H

#include "dynaslice.h"

#include <vtkDataArray.h>
#include <vtkImplicitFunction.h>
#include <vtkIndent.h>
#include <vtkObjectFactory.h>

#include <atomic>
#include <cstdint>
#include <limits>
#include <ostream>
#include <vector>

class vtkDynaSliceFunction : public vtkImplicitFunction
{
public:
  static vtkDynaSliceFunction* New() { VTK_STANDARD_NEW_BODY(vtkDynaSliceFunction); }
  vtkTypeMacro(vtkDynaSliceFunction, vtkImplicitFunction);

  /** Loads and owns a model file; returns DS_OK or a DS_E_* code (the old model is kept then). */
  int LoadModel(const char* path)
  {
    DsModel* loaded = nullptr;
    const int rc = ds_model_open(path, &loaded);
    if (rc == DS_OK)
    {
      this->Release();
      this->Model = loaded;
      this->Owned = loaded;
      this->Reported = false;
      this->Modified();
    }
    return rc;
  }

  /**
   * Uses a model owned by the caller, who keeps it alive while this function is used: one model
   * can then back one function per class.
   */
  void SetSharedModel(const DsModel* model)
  {
    this->Release();
    this->Model = model;
    this->Reported = false;
    this->Modified();
  }

  /** The model in use (NULL before one is set); for ds_bounds, ds_time_range and friends. */
  const DsModel* GetModel() const { return this->Model; }

  /** The class k (1..K) whose signed distance this function is. Default 1. */
  vtkSetMacro(Class, uint32_t);
  vtkGetMacro(Class, uint32_t);

  /**
   * The world time of the surface, in the model's time range (default 0). With a model in place,
   * a time outside the range is reported through vtkErrorMacro (and evaluation gives NaN).
   */
  void SetTime(double time)
  {
    if (this->Time == time)
    {
      return;
    }
    this->Time = time;
    this->Reported = false;
    this->Modified();
    if (this->Model)
    {
      this->Report(this->CheckTime());
    }
  }
  vtkGetMacro(Time, double);

  /**
   * DS_OK when the model answers at the current time, DS_E_TIME_OUT_OF_RANGE (detail in
   * ds_last_error_message) when the time is outside its range, DS_E_NULL_POINTER without a model.
   */
  int CheckTime() const { return ds_check_time(this->Model, static_cast<float>(this->Time)); }

  using vtkImplicitFunction::EvaluateFunction;

  /** f^k at world point x (world units, negative inside); NaN without a usable model/class. */
  double EvaluateFunction(double x[3]) override
  {
    float f[DS_MAX_CLASSES];
    const float p[3] = { static_cast<float>(x[0]), static_cast<float>(x[1]),
      static_cast<float>(x[2]) };
    if (!this->Usable() ||
      this->Report(ds_eval(this->Model, p, static_cast<float>(this->Time), f, DS_MAX_CLASSES)) !=
        DS_OK)
    {
      return std::numeric_limits<double>::quiet_NaN();
    }
    return f[this->Class - 1];
  }

  /** The exact spatial gradient ∇ₓf^k at world point x; NaN without a usable model/class. */
  void EvaluateGradient(double x[3], double g[3]) override
  {
    float f[DS_MAX_CLASSES], grad[3 * DS_MAX_CLASSES];
    const float p[3] = { static_cast<float>(x[0]), static_cast<float>(x[1]),
      static_cast<float>(x[2]) };
    const bool ok = this->Usable() &&
      this->Report(ds_eval_grad(
        this->Model, p, static_cast<float>(this->Time), f, grad, DS_MAX_CLASSES)) == DS_OK;
    for (int d = 0; d < 3; d++)
    {
      g[d] = ok ? grad[3 * (this->Class - 1) + d] : std::numeric_limits<double>::quiet_NaN();
    }
  }

  /**
   * f^k at every point (3-component tuples) of `input` into the 1-component `output`, through
   * the library's batch path.
   */
  void EvaluateFunction(vtkDataArray* input, vtkDataArray* output) override
  {
    const vtkIdType n = input->GetNumberOfTuples();
    output->SetNumberOfComponents(1);
    output->SetNumberOfTuples(n);
    const size_t k = this->Model ? ds_num_classes(this->Model) : 0;
    std::vector<float> xyz(3 * static_cast<size_t>(n)), t(static_cast<size_t>(n));
    std::vector<float> f(static_cast<size_t>(n) * k);
    for (vtkIdType i = 0; i < n; i++)
    {
      double p[3];
      input->GetTuple(i, p);
      for (int d = 0; d < 3; d++)
      {
        xyz[3 * static_cast<size_t>(i) + d] = static_cast<float>(p[d]);
      }
      t[static_cast<size_t>(i)] = static_cast<float>(this->Time);
    }
    const bool ok = this->Usable() && input->GetNumberOfComponents() == 3 &&
      (n == 0 ||
        this->Report(ds_eval_batch(
          this->Model, static_cast<size_t>(n), xyz.data(), t.data(), f.data())) == DS_OK);
    for (vtkIdType i = 0; i < n; i++)
    {
      output->SetTuple1(i,
        ok ? f[static_cast<size_t>(i) * k + this->Class - 1]
           : std::numeric_limits<double>::quiet_NaN());
    }
  }

  void PrintSelf(ostream& os, vtkIndent indent) override
  {
    this->Superclass::PrintSelf(os, indent);
    os << indent << "Model: " << this->Model << (this->Owned ? " (owned)" : " (shared)") << "\n";
    os << indent << "Class: " << this->Class << "\n";
    os << indent << "Time: " << this->Time << "\n";
  }

protected:
  vtkDynaSliceFunction() = default;
  ~vtkDynaSliceFunction() override { this->Release(); }

private:
  vtkDynaSliceFunction(const vtkDynaSliceFunction&) = delete;
  void operator=(const vtkDynaSliceFunction&) = delete;

  /**
   * Reports a failed library call through vtkErrorMacro with the library's message (thread-local,
   * so it is this call's), once until the model or time changes: evaluation runs per point, on
   * many threads, and one message says it all. Returns `rc`.
   */
  int Report(int rc)
  {
    if (rc != DS_OK && !this->Reported.exchange(true))
    {
      vtkErrorMacro(<< ds_last_error_message());
    }
    return rc;
  }

  bool Usable() const
  {
    return this->Model && this->Class >= 1 && this->Class <= ds_num_classes(this->Model);
  }

  void Release()
  {
    ds_model_free(this->Owned);
    this->Owned = nullptr;
    this->Model = nullptr;
  }

  const DsModel* Model = nullptr;
  DsModel* Owned = nullptr; // == Model when this object loaded it
  uint32_t Class = 1;
  double Time = 0.0;
  std::atomic<bool> Reported{ false }; // a failure was reported for this model and time
};

#endif /* DYNASLICE_VTK_H */

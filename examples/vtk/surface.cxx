// Extracts the surface of one class of a DynaSlice model at one time with VTK: samples
// vtkDynaSliceFunction (include/dynaslice_vtk.h) on a grid over the model's bounds with
// vtkSampleFunction, contours f = 0 with vtkFlyingEdges3D and writes a .vtp.
//
// Usage: dynaslice_surface MODEL.dsm CLASS TIME RESOLUTION OUT.vtp
//
// TIME must lie in the model's time range (ds_time_range): any other is reported through VTK's
// error macro and the program exits 1 before sampling, as the function never extrapolates.
//
// Prints the mesh's enclosed volume and area (vtkMassProperties), its boundary edges (0 for a
// closed surface), the largest |f| at the mesh's vertices (through the batch path) and the
// largest gap between EvaluateGradient and central differences of EvaluateFunction.
#include "dynaslice_vtk.h"

#include <vtkFeatureEdges.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkMassProperties.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSampleFunction.h>
#include <vtkXMLPolyDataWriter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv)
{
  if (argc != 6)
  {
    std::fprintf(stderr, "usage: %s MODEL.dsm CLASS TIME RESOLUTION OUT.vtp\n", argv[0]);
    return 2;
  }
  vtkNew<vtkDynaSliceFunction> function;
  const int rc = function->LoadModel(argv[1]);
  if (rc != DS_OK)
  {
    std::fprintf(stderr, "%s: %s\n", ds_error_string(rc), ds_last_error_message());
    return 1;
  }
  function->SetClass(static_cast<uint32_t>(std::atoi(argv[2])));
  function->SetTime(std::atof(argv[3])); // reports a time outside the range (vtkErrorMacro)
  if (function->CheckTime() != DS_OK)
  {
    return 1;
  }
  const int res = std::atoi(argv[4]);
  float lo[3], hi[3];
  ds_bounds(function->GetModel(), lo, hi);

  vtkNew<vtkSampleFunction> sampler;
  sampler->SetImplicitFunction(function);
  sampler->SetModelBounds(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]);
  sampler->SetSampleDimensions(res, res, res);
  sampler->ComputeNormalsOn(); // through EvaluateGradient
  vtkNew<vtkFlyingEdges3D> contour;
  contour->SetInputConnection(sampler->GetOutputPort());
  contour->SetValue(0, 0.0);
  contour->Update();
  vtkPolyData* mesh = contour->GetOutput();
  if (mesh->GetNumberOfPolys() == 0)
  {
    std::fprintf(stderr, "empty surface: is class %s in 1..K?\n", argv[2]);
    return 1;
  }

  vtkNew<vtkMassProperties> mass;
  mass->SetInputData(mesh);
  mass->Update();
  vtkNew<vtkFeatureEdges> edges;
  edges->SetInputData(mesh);
  edges->BoundaryEdgesOn();
  edges->FeatureEdgesOff();
  edges->NonManifoldEdgesOn();
  edges->ManifoldEdgesOff();
  edges->Update();

  // The mesh's vertices lie on f = 0 up to the grid's interpolation error.
  vtkNew<vtkFloatArray> at_vertices;
  function->FunctionValue(mesh->GetPoints()->GetData(), at_vertices);
  double max_f = 0.0;
  for (vtkIdType i = 0; i < at_vertices->GetNumberOfTuples(); i++)
  {
    max_f = std::max(max_f, std::fabs(static_cast<double>(at_vertices->GetValue(i))));
  }
  // The exact gradient against central differences of the function, at some vertices.
  double max_gap = 0.0;
  const double h = 1e-2 * (hi[0] - lo[0]) / res;
  for (vtkIdType i = 0; i < mesh->GetNumberOfPoints(); i += 97)
  {
    double p[3], g[3];
    mesh->GetPoint(i, p);
    function->EvaluateGradient(p, g);
    for (int d = 0; d < 3; d++)
    {
      double a[3] = { p[0], p[1], p[2] }, b[3] = { p[0], p[1], p[2] };
      a[d] += h;
      b[d] -= h;
      const double fd = (function->EvaluateFunction(a) - function->EvaluateFunction(b)) / (2 * h);
      max_gap = std::max(max_gap, std::fabs(fd - g[d]));
    }
  }

  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->SetInputData(mesh);
  writer->SetFileName(argv[5]);
  if (writer->Write() != 1)
  {
    std::fprintf(stderr, "cannot write %s\n", argv[5]);
    return 1;
  }
  std::printf("triangles %lld\n", static_cast<long long>(mesh->GetNumberOfPolys()));
  std::printf("volume %.3f\n", mass->GetVolume());
  std::printf("area %.3f\n", mass->GetSurfaceArea());
  std::printf("open edges %lld\n", static_cast<long long>(edges->GetOutput()->GetNumberOfLines()));
  std::printf("max |f| at vertices %.4g\n", max_f);
  std::printf("max gradient gap %.4g\n", max_gap);
  return 0;
}

#include <deal.II/numerics/data_out.h>

#include <vi/estimators.h>
#include <vi/field_output.h>

#include <list>

namespace VI
{
  using namespace dealii;

  template <int dim>
  struct FieldOutput<dim>::Data
  {
    const Mapping<dim> &mapping;
    const bool          curved_cells;
    /// Of the patches: the element's, whose functions they show.
    const unsigned int degree;
    /// The cell fields this object owns (the partition, the indicators),
    /// declared before the DataOut that refers to them, so they outlive it.
    std::list<dealii::Vector<float>> cell_fields;
    DataOut<dim>                     data_out;

    Data(const Mapping<dim>    &mapping,
         const bool             curved_cells,
         const DoFHandler<dim> &dof_handler)
        : mapping(mapping)
        , curved_cells(curved_cells)
        , degree(dof_handler.get_fe().degree)
    {
    }

    void
    add_cell_field(const dealii::Vector<float> &field, const std::string &name)
    {
      data_out.add_data_vector(field, name, DataOut<dim>::type_cell_data);
    }
  };


  template <int dim>
  FieldOutput<dim>::FieldOutput(const Mapping<dim>    &mapping,
                                const bool             curved_cells,
                                const DoFHandler<dim> &dof_handler,
                                const MembraneFields  &fields)
      : data(std::make_unique<Data>(mapping, curved_cells, dof_handler))
  {
    Assert((fields.contact_set == nullptr) !=
             (fields.contact_fraction == nullptr),
           ExcMessage("Give the contact set or the contact fraction."));
    DataOut<dim> &data_out = data->data_out;
    data_out.attach_dof_handler(dof_handler);
    data_out.add_data_vector(fields.u1, "u1");
    data_out.add_data_vector(fields.u2, "u2");
    data_out.add_data_vector(fields.gap, "gap");
    data_out.add_data_vector(fields.lambda, "lambda");
    if (fields.contact_set)
      data_out.add_data_vector(*fields.contact_set, "contact");
    else
      data->add_cell_field(*fields.contact_fraction, "contact");

    const Triangulation<dim> &triangulation = dof_handler.get_triangulation();
    dealii::Vector<float>    &partition =
      data->cell_fields.emplace_back(triangulation.n_active_cells());
    partition = triangulation.locally_owned_subdomain();
    data->add_cell_field(partition, "partition");
  }


  template <int dim>
  FieldOutput<dim>::~FieldOutput() = default;


  template <int dim>
  void
  FieldOutput<dim>::add_indicators(const ContactEstimate *estimate)
  {
    if (estimate == nullptr)
      return;
    for (auto &[name, values] : cell_indicators(*estimate))
      data->add_cell_field(data->cell_fields.emplace_back(std::move(values)),
                           name);
  }


  template <int dim>
  void
  FieldOutput<dim>::add_cell_field(const dealii::Vector<float> &field,
                                   const std::string           &name)
  {
    data->add_cell_field(field, name);
  }


  template <int dim>
  std::string
  FieldOutput<dim>::write(const std::string          &directory,
                          const unsigned int          counter,
                          const unsigned int          n_digits,
                          const MPI_Comm              comm,
                          const std::optional<double> time)
  {
    DataOut<dim> &data_out = data->data_out;
    data_out.build_patches(data->mapping,
                           data->degree,
                           data->curved_cells ?
                             DataOut<dim>::curved_inner_cells :
                             DataOut<dim>::curved_boundary);
    if (time)
      {
        DataOutBase::VtkFlags flags;
        flags.time  = *time;
        flags.cycle = counter;
        data_out.set_flags(flags);
      }
    return data_out.write_vtu_with_pvtu_record(
      directory + "/", "solution", counter, comm, n_digits, 8);
  }


  template class FieldOutput<2>;
} // namespace VI
